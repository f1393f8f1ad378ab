// The URDF loader on arbitrary text. Input: the first line names the tip link (empty: the tree's
// single leaf), the rest is the URDF. The loader either throws ModelError or returns a model the
// algorithms can run on: unit axes, ordered finite limits, finite and physical body inertias, and
// finite kinematics and dynamics at the middle of the limits (forward dynamics too, unless the
// loader's start-up check says why M is singular there).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/inertia.hpp"
#include "core/model/urdf.hpp"
#include "fuzz/check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace chasles;
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t newline = input.find('\n');
  UrdfOptions options;
  if (newline != std::string::npos) options.tip_link = input.substr(0, newline);
  const std::string xml = newline == std::string::npos ? input : input.substr(newline + 1);
  try {
    const RobotModel model = load_urdf_string(xml, options, "fuzz input");
    Eigen::VectorXd q(model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      const Joint& joint = model.joint(i);
      FUZZ_CHECK(std::abs(joint.axis.norm() - 1.0) < 1e-9);
      FUZZ_CHECK(std::isfinite(joint.limits.lower) && std::isfinite(joint.limits.upper));
      FUZZ_CHECK(joint.limits.lower <= joint.limits.upper);
      FUZZ_CHECK(joint.limits.velocity > 0.0 && joint.limits.effort > 0.0);
      FUZZ_CHECK(model.inertia(i).allFinite());
      const SpatialInertia& G = model.body_inertia(i);
      FUZZ_CHECK(check_inertia(G.mass, inertia_about_centre_of_mass(G.mass, G.h, G.I)).physical());
      q[i] = 0.5 * (joint.limits.lower + joint.limits.upper);
    }
    Data data_(model);
    FUZZ_CHECK(forward_kinematics(model, data_, q).matrix().allFinite());
    FUZZ_CHECK(body_jacobian(model, data_, q).allFinite());
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.dof());
    FUZZ_CHECK(inverse_dynamics(model, data_, q, zero, zero).allFinite());
    if (mass_matrix_defect(model, data_, q).empty()) {
      FUZZ_CHECK(forward_dynamics(model, data_, q, zero, zero).allFinite());
    }
  } catch (const ModelError&) {
    // refused, with a message: what bad input should get
  }
  return 0;
}
