// chasles_bench: chasles against Orocos KDL 1.5.1, same robots, same quantities, same run.
//
// Benchmarks are named "<library>/<robot>/<quantity>", library ∈ {chasles, kdl}, robot ∈ {ur5,
// panda}, quantity ∈ {fk, jacobian_space, jacobian_body, rnea, gravity, mass_matrix,
// forward_dynamics}; tools/bench.sh runs them and prints the chasles/KDL ratios.
//
// Fairness:
// - Both sides are called from this one binary, compiled with the same flags (the build type's,
//   Release: -O3). KDL's library itself is Debian's build (-O2, no -march); there is nothing to do
//   about that short of rebuilding KDL. chasles is a static library, KDL a shared one: every call
//   is a real, non-inlined call on both sides.
// - Models and solvers are built once, before timing. Every iteration takes the next entry of a
//   precomputed, seeded random table of 256 (q, q̇, q̈, τ), q within the joint limits, already in
//   each library's own types (Eigen vectors, KDL::JntArray), so no conversion is timed and nothing
//   can be folded away; every result goes through benchmark::DoNotOptimize.
// - Before timing, main() checks that both libraries compute the same quantities (tip pose, both
//   Jacobians, τ, g, M, q̈) on a few table entries and refuses to run if they do not: timing two
//   different computations would be worthless.
//
// What exactly is compared (chasles is Lynch & Park, angular first; KDL's twists are linear
// first, so the checks permute rows):
// - fk: forward_kinematics vs ChainFkSolverPos_recursive::JntToCart, tip pose in the base frame.
// - jacobian_space: space_jacobian vs ChainJntToJacSolver::JntToJac. KDL's Jacobian is expressed
//   in the base frame with its reference point at the tip (a "hybrid" Jacobian), not the space
//   Jacobian; it is KDL's native Jacobian and the standard comparison anchor. It carries the same
//   information: columns (v_tip, ω) = (v_s + ω × p_tip, ω).
// - jacobian_body: body_jacobian vs JntToCart + JntToJac + Jacobian::changeBase(R_sb⁻¹). KDL has
//   no body Jacobian and its JntToJac does not expose the tip pose it computes, so one FK pass is
//   needed for R_sb; with the reference point already at the tip only the orientation changes,
//   and changeBase (a rotation of each column) is the cheapest correct conversion (changeRefFrame
//   would also move the reference point, for nothing).
// - rnea: inverse_dynamics vs ChainIdSolver_RNE::CartToJnt, gravity (0, 0, −9.81), zero
//   external wrenches.
// - gravity: gravity_torques vs ChainDynParam::JntToGravity.
// - mass_matrix: mass_matrix vs ChainDynParam::JntToMass.
// - forward_dynamics: forward_dynamics vs ChainFdSolver_RNE::CartToJnt (present in KDL 1.5.1:
//   M by ChainDynParam, bias by RNE with q̈ = 0, then an LDLᵀ solve), zero external wrenches.
//
// Off-chain links: chasles locks joints off the root → tip chain at 0 and rigidly attaches their
// links' inertia to the body they hang from (the panda's fingers ride on panda_hand).
// KDL's Tree::getChain(root, tip) simply leaves them out. So that the dynamics agree and can be
// checked, the KDL chain gets the same treatment here: the inertia of every off-chain subtree,
// at q = 0, is added to the chain segment it hangs from. That changes numbers only, not the
// number of segments, so KDL's cost is the same as on the plain getChain() chain. (kdl_parser
// warns that the panda's root link panda_link0 has an inertia KDL ignores: the root is the fixed
// base, whose inertia enters no joint torque, so chasles's dynamics ignore it too.)
#include <benchmark/benchmark.h>

#include <kdl/chain.hpp>
#include <kdl/chaindynparam.hpp>
#include <kdl/chainfdsolver_recursive_newton_euler.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/jntspaceinertiamatrix.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>

#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "comparison.hpp"

namespace {

using chasles::bench::add;
using chasles::bench::Check;
using chasles::bench::keep;
using chasles::bench::kChecked;

constexpr double kTolerance = 1e-6;  // relative to the largest entry (at least 1)

// One table entry, in both libraries' types: the drawn Eigen vectors and their copies as KDL::JntArray.
struct Sample : chasles::bench::Sample {
  explicit Sample(const chasles::bench::Sample& drawn) : chasles::bench::Sample(drawn) {
    kq.data = q;
    kqd.data = qd;
    kqdd.data = qdd;
    ktau.data = tau;
  }

  KDL::JntArray kq, kqd, kqdd, ktau;
};

// The inertia of the subtree rooted at `element`, every joint in it at 0, in that segment's frame.
KDL::RigidBodyInertia subtree_inertia(const KDL::SegmentMap::const_iterator& element) {
  KDL::RigidBodyInertia I = GetTreeElementSegment(element->second).getInertia();
  for (const auto& child : GetTreeElementChildren(element->second)) {
    I = I + GetTreeElementSegment(child->second).pose(0.0) * subtree_inertia(child);
  }
  return I;
}

// KDL's model of one robot beside chasles's, its solvers and output buffers, and the sample table.
// Never copied or moved (no ChaslesRobot is): KDL's solvers keep a reference to `chain`.
struct Robot : chasles::bench::ChaslesRobot {
  Robot(std::string robot_name, const std::string& urdf, const std::string& tip);

  KDL::Chain chain;
  std::unique_ptr<KDL::ChainFkSolverPos_recursive> fk;
  std::unique_ptr<KDL::ChainJntToJacSolver> jacobian;
  std::unique_ptr<KDL::ChainIdSolver_RNE> rnea;
  std::unique_ptr<KDL::ChainDynParam> dyn;
  std::unique_ptr<KDL::ChainFdSolver_RNE> fd;
  KDL::Frame frame;
  KDL::Jacobian jac;
  KDL::JntArray tau, g, qdd;
  KDL::JntSpaceInertiaMatrix M;
  KDL::Wrenches f_ext;

  std::vector<Sample> table;
};

Robot::Robot(std::string robot_name, const std::string& urdf, const std::string& tip)
    : ChaslesRobot(std::move(robot_name), urdf, tip) {
  KDL::Tree tree;
  if (!kdl_parser::treeFromFile(urdf, tree)) throw std::runtime_error("kdl_parser cannot read " + urdf);
  if (!tree.getChain(model.base_link(), model.tip_link(), chain)) {
    throw std::runtime_error("KDL has no chain " + model.base_link() + " -> " + model.tip_link() + " in " + urdf);
  }
  // Lock the off-chain subtrees at 0 onto the chain, as chasles does (see the top of the file).
  std::set<std::string> on_chain;
  for (const KDL::Segment& s : chain.segments) on_chain.insert(s.getName());
  for (KDL::Segment& s : chain.segments) {
    const auto element = tree.getSegment(s.getName());
    KDL::RigidBodyInertia I = s.getInertia();
    for (const auto& child : GetTreeElementChildren(element->second)) {
      if (on_chain.count(child->first) != 0) continue;
      I = I + GetTreeElementSegment(child->second).pose(0.0) * subtree_inertia(child);
    }
    s.setInertia(I);
  }

  // The same joints in the same order, or nothing below compares like with like.
  std::vector<std::string> kdl_joints;
  for (const KDL::Segment& s : chain.segments) {
    if (s.getJoint().getType() != KDL::Joint::Fixed) kdl_joints.push_back(s.getJoint().getName());
  }
  std::vector<std::string> chasles_joints;
  for (const chasles::Joint& j : model.joints()) chasles_joints.push_back(j.name);
  if (kdl_joints != chasles_joints) throw std::runtime_error(name + ": KDL and chasles see different joints");

  const KDL::Vector gravity(model.gravity().x(), model.gravity().y(), model.gravity().z());
  fk = std::make_unique<KDL::ChainFkSolverPos_recursive>(chain);
  jacobian = std::make_unique<KDL::ChainJntToJacSolver>(chain);
  rnea = std::make_unique<KDL::ChainIdSolver_RNE>(chain, gravity);
  dyn = std::make_unique<KDL::ChainDynParam>(chain, gravity);
  fd = std::make_unique<KDL::ChainFdSolver_RNE>(chain, gravity);
  const unsigned n = chain.getNrOfJoints();
  jac.resize(n);
  tau.resize(n);
  g.resize(n);
  qdd.resize(n);
  M.resize(n);
  f_ext.assign(chain.getNrOfSegments(), KDL::Wrench::Zero());

  for (const chasles::bench::Sample& drawn : chasles::bench::sample_table(model)) table.emplace_back(drawn);
}

// --- the agreement check ------------------------------------------------------------------------

Eigen::Matrix4d to_eigen(const KDL::Frame& F) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T(r, c) = F.M(r, c);
    T(r, 3) = F.p(r);
  }
  return T;
}

// KDL's Jacobian rows are (v, ω); chasles's (ω, v).
Eigen::MatrixXd angular_first(const KDL::Jacobian& J) {
  Eigen::MatrixXd out(6, J.columns());
  out << J.data.bottomRows<3>(), J.data.topRows<3>();
  return out;
}

void check_agreement(Robot& r, Check& check) {
  const int n = r.model.dof();
  for (int k = 0; k < kChecked; ++k) {
    const Sample& s = r.table[static_cast<size_t>(k)];
    int status = 0;

    const chasles::Transform T_sb = chasles::forward_kinematics(r.model, r.data, s.q);
    status |= r.fk->JntToCart(s.kq, r.frame);
    check.compare(r.name, "fk", k, T_sb.matrix(), to_eigen(r.frame));

    // Space Jacobian → KDL's hybrid one: (ω, v_s) → (ω, v_s + ω × p_tip).
    Eigen::MatrixXd J_hybrid = chasles::space_jacobian(r.model, r.data, s.q);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d w = J_hybrid.col(i).head<3>();
      J_hybrid.col(i).tail<3>() += w.cross(T_sb.translation());
    }
    status |= r.jacobian->JntToJac(s.kq, r.jac);
    check.compare(r.name, "jacobian_space", k, J_hybrid, angular_first(r.jac));

    const Eigen::MatrixXd J_b = chasles::body_jacobian(r.model, r.data, s.q);
    status |= r.fk->JntToCart(s.kq, r.frame);
    status |= r.jacobian->JntToJac(s.kq, r.jac);
    r.jac.changeBase(r.frame.M.Inverse());
    check.compare(r.name, "jacobian_body", k, J_b, angular_first(r.jac));

    const Eigen::VectorXd tau = chasles::inverse_dynamics(r.model, r.data, s.q, s.qd, s.qdd);
    status |= r.rnea->CartToJnt(s.kq, s.kqd, s.kqdd, r.f_ext, r.tau);
    check.compare(r.name, "rnea", k, tau, r.tau.data);

    const Eigen::VectorXd g = chasles::gravity_torques(r.model, r.data, s.q);
    status |= r.dyn->JntToGravity(s.kq, r.g);
    check.compare(r.name, "gravity", k, g, r.g.data);

    const Eigen::MatrixXd M = chasles::mass_matrix(r.model, r.data, s.q);
    status |= r.dyn->JntToMass(s.kq, r.M);
    check.compare(r.name, "mass_matrix", k, M, r.M.data);

    const Eigen::VectorXd qdd = chasles::forward_dynamics(r.model, r.data, s.q, s.qd, s.tau);
    status |= r.fd->CartToJnt(s.kq, s.kqd, s.ktau, r.f_ext, r.qdd);
    check.compare(r.name, "forward_dynamics", k, qdd, r.qdd.data);

    if (status != 0) check.failures += "  " + r.name + ": a KDL solver returned an error\n";
  }
}

// --- the benchmarks -----------------------------------------------------------------------------

// chasles and KDL side by side for each quantity, so that drift (clock, temperature) hits both.
void register_benchmarks(Robot& r) {
  using namespace chasles;
  add("chasles", r, "fk", [](Robot& x, const Sample& s) { keep(forward_kinematics(x.model, x.data, s.q)); });
  add("kdl", r, "fk", [](Robot& x, const Sample& s) {
    x.fk->JntToCart(s.kq, x.frame);
    keep(x.frame);
  });

  add("chasles", r, "jacobian_space", [](Robot& x, const Sample& s) { keep(space_jacobian(x.model, x.data, s.q)); });
  add("kdl", r, "jacobian_space", [](Robot& x, const Sample& s) {
    x.jacobian->JntToJac(s.kq, x.jac);
    keep(x.jac);
  });

  add("chasles", r, "jacobian_body", [](Robot& x, const Sample& s) { keep(body_jacobian(x.model, x.data, s.q)); });
  add("kdl", r, "jacobian_body", [](Robot& x, const Sample& s) {
    x.fk->JntToCart(s.kq, x.frame);
    x.jacobian->JntToJac(s.kq, x.jac);
    x.jac.changeBase(x.frame.M.Inverse());
    keep(x.jac);
  });

  add("chasles", r, "rnea",
      [](Robot& x, const Sample& s) { keep(inverse_dynamics(x.model, x.data, s.q, s.qd, s.qdd)); });
  add("kdl", r, "rnea", [](Robot& x, const Sample& s) {
    x.rnea->CartToJnt(s.kq, s.kqd, s.kqdd, x.f_ext, x.tau);
    keep(x.tau);
  });

  add("chasles", r, "gravity", [](Robot& x, const Sample& s) { keep(gravity_torques(x.model, x.data, s.q)); });
  add("kdl", r, "gravity", [](Robot& x, const Sample& s) {
    x.dyn->JntToGravity(s.kq, x.g);
    keep(x.g);
  });

  add("chasles", r, "mass_matrix", [](Robot& x, const Sample& s) { keep(mass_matrix(x.model, x.data, s.q)); });
  add("kdl", r, "mass_matrix", [](Robot& x, const Sample& s) {
    x.dyn->JntToMass(s.kq, x.M);
    keep(x.M);
  });

  add("chasles", r, "forward_dynamics",
      [](Robot& x, const Sample& s) { keep(forward_dynamics(x.model, x.data, s.q, s.qd, s.tau)); });
  add("kdl", r, "forward_dynamics", [](Robot& x, const Sample& s) {
    x.fd->CartToJnt(s.kq, s.kqd, s.ktau, x.f_ext, x.qdd);
    keep(x.qdd);
  });
}

}  // namespace

int main(int argc, char** argv) {
  return chasles::bench::run_comparison(
      argc, argv,
      {"chasles_bench", "KDL", kTolerance, "chasles_kdl_agreement",
       "fk, jacobian_space, jacobian_body, rnea, gravity, mass_matrix, forward_dynamics agree"},
      check_agreement, register_benchmarks);
}
