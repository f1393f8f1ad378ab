// Two scenes compared field by field, for the tests of the scene's file and of its message: every
// number to the bit but rotations (and the planes' offsets, a rotation's product), within
// `rotation_tolerance`.
#pragma once

#include <gtest/gtest.h>

#include "core/geometry/proximity.hpp"

namespace chasles::testing {

inline void expect_same(const geometry::Scene& a, const geometry::Scene& b, double rotation_tolerance) {
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (size_t k = 0; k < a.objects.size(); ++k) {
    const geometry::SceneObject &x = a.objects[k], &y = b.objects[k];
    SCOPED_TRACE(x.name);
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.shape.kind, y.shape.kind);
    EXPECT_EQ(x.shape.radius, y.shape.radius);
    EXPECT_EQ(x.shape.half_length, y.shape.half_length);
    EXPECT_EQ(x.shape.half_extents, y.shape.half_extents);
    EXPECT_EQ(x.shape.vertices, y.shape.vertices);
    EXPECT_EQ(x.shape.neighbours, y.shape.neighbours);
    EXPECT_EQ(x.T_base_object.translation(), y.T_base_object.translation());
    EXPECT_LE((x.T_base_object.linear() - y.T_base_object.linear()).cwiseAbs().maxCoeff(), rotation_tolerance);
    EXPECT_EQ(x.clearance.stop, y.clearance.stop);
    EXPECT_EQ(x.clearance.influence, y.clearance.influence);
  }
  ASSERT_EQ(a.planes.size(), b.planes.size());
  for (size_t k = 0; k < a.planes.size(); ++k) {
    const geometry::SafetyPlane &x = a.planes[k], &y = b.planes[k];
    SCOPED_TRACE(x.name);
    EXPECT_EQ(x.name, y.name);
    EXPECT_LE((x.normal - y.normal).cwiseAbs().maxCoeff(), rotation_tolerance);
    EXPECT_NEAR(x.offset, y.offset, rotation_tolerance);
    EXPECT_EQ(x.links, y.links);
    EXPECT_EQ(x.clearance.stop, y.clearance.stop);
    EXPECT_EQ(x.clearance.influence, y.clearance.influence);
  }
}

}  // namespace chasles::testing
