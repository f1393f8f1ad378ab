// The distance engine against coal (Pinocchio's collision library) on the same convex shapes:
// 10,000 random configurations of the Panda, the UR5 and the iiwa, every pair of the collision
// model, the values pip coal computed (tests/data/collision, its README says how). The
// configurations are drawn again here with the generator the script used; the object poses are
// chasles's own forward kinematics, so the comparison covers the loader's placements too.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>

#include "core/geometry/collision_model.hpp"
#include "core/geometry/distance.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::geometry {
namespace {

using testing::data_path;

// splitmix64 (Steele, Lea and Flood 2014), as tools/reference/coal_distances.py draws.
struct SplitMix64 {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

// The largest value of n·x over the shape at pose T: its support function, margins included.
double support_value(const Shape& shape, const Transform& T, const Vector3d& n) {
  int vertex = 0;
  return n.dot(T * support_of_core(shape, T.linear().transpose() * n, vertex)) + margin_of(shape);
}

// A lower bound on the signed distance from the plane normal to n: how far b's nearest point
// along n lies beyond a's farthest (negative: how much they overlap along n, which is at least the
// depth they overlap by). The engine's value is an upper bound by construction (the distance
// between two points of the shapes apart; EPA's polytope inside the shapes' difference when they
// overlap), so the two together bound the exact signed distance from both sides.
double gap_along(const Shape& a, const Transform& T_a, const Shape& b, const Transform& T_b, const Vector3d& n) {
  return -support_value(b, T_b, -n) - support_value(a, T_a, n);
}

struct Case {
  std::string robot, urdf, tip, srdf;
};

// coal's GJK and EPA stop at a gap of 1e-6 (its default); float32 rounds the stored values by
// less than 6e-8 m.
constexpr double kCoalTolerance = 1e-6;
// How far chasles's value may be from the exact distance, bounded from below by the separating
// plane along its own normal: the engine's tolerance (1e-9), with room for the rounding between
// its bound and this one, computed in another frame.
constexpr double kExact = 1.1e-9;

struct Worst {
  double error = 0.0;
  int config = -1;
  std::string pair;
  double ours = 0.0, coal = 0.0;
};

void compare_with_coal(const Case& c) {
  const nlohmann::json ref = nlohmann::json::parse(testing::read_file(data_path("collision/" + c.robot + ".json")));
  UrdfOptions urdf_options;
  urdf_options.tip_link = c.tip;
  const RobotModel model = load_urdf_file(data_path(c.urdf), urdf_options);
  GeometryOptions options{{data_path("packages")}, c.srdf.empty() ? "" : data_path("packages/" + c.srdf)};
  const CollisionModel collision = load_collision_model(data_path(c.urdf), model, options);

  ASSERT_EQ(model.dof(), static_cast<int>(ref["joints"].size()));
  for (int i = 0; i < model.dof(); ++i) EXPECT_EQ(model.joint(i).name, ref["joints"][i].get<std::string>());

  // The script's pairs by name, mapped onto ours: the same set, but for pairs of objects on one
  // body, which chasles never checks (their distance cannot change).
  std::map<std::string, int> index;
  for (size_t k = 0; k < collision.objects.size(); ++k) index[collision.objects[k].name] = static_cast<int>(k);
  std::map<std::pair<int, int>, int> ours;
  for (size_t p = 0; p < collision.pairs.size(); ++p) ours[collision.pairs[p]] = static_cast<int>(p);
  const auto& objects = ref["objects"];
  struct Column {
    int column;
    int pair;
  };
  std::vector<Column> columns;
  for (size_t column = 0; column < ref["pairs"].size(); ++column) {
    const std::string a = objects[ref["pairs"][column][0].get<int>()]["name"];
    const std::string b = objects[ref["pairs"][column][1].get<int>()]["name"];
    ASSERT_TRUE(index.count(a) && index.count(b)) << a << " " << b;
    const auto found = ours.find({std::min(index[a], index[b]), std::max(index[a], index[b])});
    if (found == ours.end()) {
      EXPECT_EQ(collision.objects[index[a]].body, collision.objects[index[b]].body) << a << " – " << b;
      continue;
    }
    columns.push_back({static_cast<int>(column), found->second});
  }
  EXPECT_EQ(columns.size(), collision.pairs.size()) << "a pair of ours coal did not compute";

  const int configurations = ref["configurations"];
  const size_t width = ref["pairs"].size();
  const std::string bytes = testing::read_file(data_path("collision/" + ref["distances_file"].get<std::string>()));
  ASSERT_EQ(bytes.size(), configurations * width * sizeof(float));

  SplitMix64 random{ref["seed"].get<uint64_t>()};
  Data data(model);
  std::vector<Transform> poses(collision.objects.size());
  std::vector<DistanceCache> caches(collision.pairs.size());
  Worst worst, slack;
  int over = 0, coal_short = 0;
  for (int config = 0; config < configurations; ++config) {
    Eigen::VectorXd q(model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      const double lo = ref["limits"][i][0], hi = ref["limits"][i][1];
      q[i] = lo + random.uniform() * (hi - lo);
    }
    if (config == 0) {
      for (int i = 0; i < model.dof(); ++i) ASSERT_EQ(q[i], ref["first_q"][i].get<double>()) << "the generator";
    }
    forward_kinematics(model, data, q);
    for (size_t k = 0; k < collision.objects.size(); ++k) {
      const CollisionObject& o = collision.objects[k];
      poses[k] = data.T_body[o.body] * o.T_body_object;
    }
    for (const Column& column : columns) {
      const auto [a, b] = collision.pairs[column.pair];
      const Distance d = signed_distance(collision.objects[a].shape, poses[a], collision.objects[b].shape, poses[b],
                                         caches[column.pair]);
      float stored;
      std::memcpy(&stored, bytes.data() + (config * width + column.column) * sizeof(float), sizeof(float));
      const std::string name = collision.objects[a].name + " – " + collision.objects[b].name;
      const double bound = gap_along(collision.objects[a].shape, poses[a], collision.objects[b].shape, poses[b], d.normal);
      if (d.distance - bound > slack.error) slack = {d.distance - bound, config, name, d.distance, bound};
      const double error = std::abs(d.distance - stored);
      if (error > worst.error) worst = {error, config, name, d.distance, stored};
      if (error <= kCoalTolerance) continue;
      // Further from coal than its tolerance: acceptable only where coal stopped short, above a
      // value of ours that the plane along our normal proves exact.
      if (d.distance < stored && d.distance - bound <= kExact) {
        ++coal_short;
      } else {
        ++over;
      }
    }
  }
  std::printf("%s: %d configurations × %zu pairs; largest difference from coal %.3g m (configuration %d, %s: "
              "ours %.9f, coal %.9f); %d beyond coal's tolerance, all where coal stopped above a distance of ours "
              "proven exact; largest gap between ours and the plane's bound %.3g m\n",
              c.robot.c_str(), configurations, columns.size(), worst.error, worst.config, worst.pair.c_str(), worst.ours,
              worst.coal, coal_short, slack.error);
  EXPECT_EQ(over, 0) << "distances further than " << kCoalTolerance << " m from coal's and not proven; the largest "
                     << worst.error << " at configuration " << worst.config << ", " << worst.pair;
  EXPECT_LE(slack.error, kExact) << "configuration " << slack.config << ", " << slack.pair << ": ours " << slack.ours
                                 << ", the plane along its normal " << slack.coal;
}

TEST(CoalReference, PandaSelfDistancesEqualCoalsOnTheSameHulls) {
  compare_with_coal({"panda", "panda.urdf", "panda_hand", "example-robot-data/robots/panda_description/srdf/panda.srdf"});
}

TEST(CoalReference, Ur5SelfDistancesEqualCoalsOnTheSameHulls) {
  compare_with_coal({"ur5", "ur5.urdf", "tool0", "example-robot-data/robots/ur_description/srdf/ur5.srdf"});
}

TEST(CoalReference, IiwaSelfDistancesEqualCoalsOnTheSameShapes) {
  compare_with_coal({"iiwa", "iiwa14.urdf", "iiwa_link_ee", ""});
}

}  // namespace
}  // namespace chasles::geometry
