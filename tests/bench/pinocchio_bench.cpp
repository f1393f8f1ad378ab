// chasles_pinocchio_bench: chasles against Pinocchio, same robots, same quantities, same run.
//
// Benchmarks are named "<library>/<robot>/<quantity>", library ∈ {chasles, pinocchio}, robot ∈
// {ur5, panda}, quantity ∈ {fk, jacobian_body, rnea, mass_matrix, forward_dynamics}; Pinocchio's
// mass_matrix and forward_dynamics also as "<quantity>.world", in its other convention (below).
// tools/bench.sh runs them and prints the chasles/Pinocchio ratios against the target of
// 0.5, Pinocchio's time being the faster of its two conventions where it has two. Built only when the bench tree is configured with -DCHASLES_PINOCCHIO_PREFIX=<prefix>, the
// cmeel prefix of the pip package `pin` that tools/pinocchio.sh installs in build-bench/venv.
//
// Fairness:
// - Pinocchio here is Pinocchio's own C++, the headers of the `pin` wheel (its version is printed
//   and recorded in the report's context), compiled into this binary with the same compiler and
//   the same flags as chasles (the build type's, Release: -O3), against the same Eigen (Debian's
//   3.4; the wheel ships none). It is used header-only, without PINOCCHIO_ENABLE_TEMPLATE_
//   INSTANTIATION, so nothing of the wheel's prebuilt libpinocchio runs: every algorithm is
//   instantiated here for Pinocchio's default joint collection (JointCollectionDefaultTpl, a
//   boost::variant of joint models, as `pinocchio::Model` is in any user's program).
// - chasles is a static library, so its calls are real calls; each Pinocchio call goes through a
//   noinline function of this file, so it is one too and cannot be folded into the loop.
// - Models are built once, before timing. Every iteration takes the next entry of a precomputed,
//   seeded random table of 256 (q, q̇, q̈, τ), q within the joint limits (comparison.hpp's, the
//   same as chasles_bench's), as Eigen vectors both libraries take as they are; every result goes
//   through benchmark::DoNotOptimize.
// - Before timing, main() checks that both libraries compute the same quantities (tip pose, J_b,
//   τ, M, q̈) on a few table entries to a relative 1e-9 and refuses to run if they do not.
//
// The Pinocchio model is built from chasles's RobotModel (as contact_bench.cpp builds its KDL
// chain), not by Pinocchio's URDF parser: that parser lives in the wheel's compiled
// libpinocchio_parsers, linked against the wheel's urdfdom 6, tinyxml2 11 and boost 1.90 beside
// Debian's urdfdom that chasles links; and chasles's model already carries what the comparison
// needs to be the same on both sides: the Panda's finger joints locked at 0 with their inertia on
// panda_hand (what pinocchio::buildReducedModel would make of them). chasles's URDF reading is
// checked independently against kdl_parser by chasles_bench. The model is what Pinocchio's own
// parser would give for these URDFs: one joint per movable joint with its URDF origin as
// placement (fixed joints merged), axis-aligned revolute joints as Pinocchio's specialised
// JointModelRX/RY/RZ (every joint of both arms is about +x, +y or +z; other axes would get
// JointModelRevoluteUnaligned), each body's inertia in its joint frame, and the tip as an
// OP_FRAME on the last joint.
//
// What exactly is compared (chasles is Lynch & Park, angular first; Pinocchio's motion vectors
// are (v, ω), linear first, so the check permutes rows):
// - fk: forward_kinematics (tip pose; it also computes every body pose) vs
//   forwardKinematics(model, data, q) (every joint placement) + updateFramePlacement(tip).
// - jacobian_body: body_jacobian vs computeFrameJacobian(model, data, q, tip, LOCAL, J): the tip
//   frame's Jacobian in the tip frame, FK pass included, as chasles's.
// - rnea: inverse_dynamics (zero tip wrench) vs rnea(model, data, q, v, a).
// - mass_matrix: mass_matrix vs crba(model, data, q, convention). Pinocchio fills only the upper
//   triangle of data.M; chasles returns the full symmetric matrix. crba is timed alone, not
//   symmetrised (a user who wants the whole matrix copies the triangle over, a few ns more):
//   chasles does a little more here.
// - forward_dynamics: forward_dynamics (zero tip wrench) vs aba(model, data, q, v, tau,
//   convention). chasles goes through M and a Cholesky solve; ABA is O(n).
// Pinocchio 4's crba and aba take a Convention: LOCAL (the default; quantities in each joint's
// frame) or WORLD (in the base frame, which also leaves more in Data). Which is faster depends on
// the algorithm (on this project's VM crba is faster in LOCAL, aba in WORLD, by 20-40 %), so both
// are timed, "<quantity>" in LOCAL and "<quantity>.world" in WORLD, both checked, and chasles is
// held to the faster.
#include <benchmark/benchmark.h>

#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/config.hpp>
#include <pinocchio/multibody.hpp>

#include <memory>
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
using chasles::bench::Sample;  // Eigen vectors, as both libraries take them

constexpr double kTolerance = 1e-9;  // relative to the largest entry (at least 1)

pinocchio::SE3 to_se3(const chasles::Transform& T) { return pinocchio::SE3(T.linear(), T.translation()); }

// The joint model Pinocchio's URDF parser would pick: a specialised one for an axis along +x, +y
// or +z, an unaligned one otherwise. A continuous joint becomes a bounded revolute one (one
// coordinate, the angle, as chasles has it) rather than Pinocchio's unbounded (cos, sin) joint;
// neither arm here has one.
pinocchio::JointModel joint_model(const chasles::Joint& joint) {
  const Eigen::Vector3d& a = joint.axis;
  const bool prismatic = joint.type == chasles::JointType::Prismatic;
  for (int k = 0; k < 3; ++k) {
    if (a == Eigen::Vector3d::Unit(k)) {
      if (prismatic) {
        if (k == 0) return pinocchio::JointModelPX();
        if (k == 1) return pinocchio::JointModelPY();
        return pinocchio::JointModelPZ();
      }
      if (k == 0) return pinocchio::JointModelRX();
      if (k == 1) return pinocchio::JointModelRY();
      return pinocchio::JointModelRZ();
    }
  }
  if (prismatic) return pinocchio::JointModelPrismaticUnaligned(a);
  return pinocchio::JointModelRevoluteUnaligned(a);
}

// chasles's body inertia (m, h = m c, I about the body origin) is exactly Pinocchio's vector of
// dynamic parameters [m, m c, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz] about the frame origin.
pinocchio::Inertia to_inertia(const chasles::SpatialInertia& G) {
  Eigen::Matrix<double, 10, 1> p;
  p << G.mass, G.h, G.I(0, 0), G.I(0, 1), G.I(1, 1), G.I(0, 2), G.I(1, 2), G.I(2, 2);
  return pinocchio::Inertia::FromDynamicParameters(p);
}

// Pinocchio's model of one robot beside chasles's, its workspace and output buffer, and the sample
// table.
struct Robot : chasles::bench::ChaslesRobot {
  Robot(std::string robot_name, const std::string& urdf, const std::string& tip);

  pinocchio::Model pmodel;
  std::unique_ptr<pinocchio::Data> pdata;
  pinocchio::FrameIndex tip = 0;
  pinocchio::Data::Matrix6x J;  // computeFrameJacobian's output; zeroed once, every column is written

  std::vector<Sample> table;
};

Robot::Robot(std::string robot_name, const std::string& urdf, const std::string& tip_link)
    : ChaslesRobot(std::move(robot_name), urdf, tip_link), table(chasles::bench::sample_table(model)) {
  pmodel.name = model.name();
  pinocchio::JointIndex parent = 0;  // the universe
  for (int i = 0; i < model.dof(); ++i) {
    const chasles::Joint& joint = model.joint(i);
    parent = pmodel.addJoint(parent, joint_model(joint), to_se3(joint.T_parent_joint), joint.name);
    pmodel.appendBodyToJoint(parent, to_inertia(model.body_inertia(i)), pinocchio::SE3::Identity());
  }
  tip = pmodel.addFrame(pinocchio::Frame(model.tip_link(), parent, to_se3(model.T_last_tip()), pinocchio::OP_FRAME));
  pmodel.gravity = pinocchio::Motion(model.gravity(), Eigen::Vector3d::Zero());
  if (pmodel.nq != model.dof() || pmodel.nv != model.dof()) {
    throw std::runtime_error(name + ": the Pinocchio model has nq = " + std::to_string(pmodel.nq) +
                             ", not one coordinate per joint");
  }
  pdata = std::make_unique<pinocchio::Data>(pmodel);
  J = pinocchio::Data::Matrix6x::Zero(6, pmodel.nv);
}

// --- Pinocchio's side, each one real call ---------------------------------------------------------

__attribute__((noinline)) const pinocchio::SE3& pin_fk(Robot& r, const Eigen::VectorXd& q) {
  pinocchio::forwardKinematics(r.pmodel, *r.pdata, q);
  return pinocchio::updateFramePlacement(r.pmodel, *r.pdata, r.tip);
}

__attribute__((noinline)) const pinocchio::Data::Matrix6x& pin_jacobian_body(Robot& r, const Eigen::VectorXd& q) {
  pinocchio::computeFrameJacobian(r.pmodel, *r.pdata, q, r.tip, pinocchio::LOCAL, r.J);
  return r.J;
}

__attribute__((noinline)) const Eigen::VectorXd& pin_rnea(Robot& r, const Sample& s) {
  return pinocchio::rnea(r.pmodel, *r.pdata, s.q, s.qd, s.qdd);
}

__attribute__((noinline)) const Eigen::MatrixXd& pin_crba(Robot& r, const Eigen::VectorXd& q,
                                                           pinocchio::Convention convention) {
  return pinocchio::crba(r.pmodel, *r.pdata, q, convention);
}

__attribute__((noinline)) const Eigen::VectorXd& pin_aba(Robot& r, const Sample& s, pinocchio::Convention convention) {
  return pinocchio::aba(r.pmodel, *r.pdata, s.q, s.qd, s.tau, convention);
}

constexpr pinocchio::Convention kConventions[] = {pinocchio::Convention::LOCAL, pinocchio::Convention::WORLD};

// --- the agreement check ------------------------------------------------------------------------

// Pinocchio's Jacobian rows are (v, ω); chasles's (ω, v).
Eigen::MatrixXd angular_first(const Eigen::MatrixXd& J) {
  Eigen::MatrixXd out(6, J.cols());
  out << J.bottomRows<3>(), J.topRows<3>();
  return out;
}

void check_agreement(Robot& r, Check& check) {
  for (int k = 0; k < kChecked; ++k) {
    const Sample& s = r.table[static_cast<size_t>(k)];

    const chasles::Transform T_sb = chasles::forward_kinematics(r.model, r.data, s.q);
    check.compare(r.name, "fk", k, T_sb.matrix(), pin_fk(r, s.q).toHomogeneousMatrix());

    const Eigen::MatrixXd J_b = chasles::body_jacobian(r.model, r.data, s.q);
    check.compare(r.name, "jacobian_body", k, J_b, angular_first(pin_jacobian_body(r, s.q)));

    const Eigen::VectorXd tau = chasles::inverse_dynamics(r.model, r.data, s.q, s.qd, s.qdd);
    check.compare(r.name, "rnea", k, tau, pin_rnea(r, s));

    const Eigen::MatrixXd M = chasles::mass_matrix(r.model, r.data, s.q);
    const Eigen::VectorXd qdd = chasles::forward_dynamics(r.model, r.data, s.q, s.qd, s.tau);
    for (const pinocchio::Convention convention : kConventions) {
      const bool world = convention == pinocchio::Convention::WORLD;
      Eigen::MatrixXd M_pin = pin_crba(r, s.q, convention);
      M_pin.triangularView<Eigen::StrictlyLower>() = M_pin.transpose();  // crba fills the upper triangle
      check.compare(r.name, world ? "mass_matrix.world" : "mass_matrix", k, M, M_pin);
      check.compare(r.name, world ? "forward_dynamics.world" : "forward_dynamics", k, qdd, pin_aba(r, s, convention));
    }
  }
}

// --- the benchmarks -----------------------------------------------------------------------------

// chasles and Pinocchio side by side for each quantity, so that drift (clock, load) hits both.
void register_benchmarks(Robot& r) {
  using namespace chasles;
  add("chasles", r, "fk", [](Robot& x, const Sample& s) { keep(forward_kinematics(x.model, x.data, s.q)); });
  add("pinocchio", r, "fk", [](Robot& x, const Sample& s) { keep(pin_fk(x, s.q)); });

  add("chasles", r, "jacobian_body", [](Robot& x, const Sample& s) { keep(body_jacobian(x.model, x.data, s.q)); });
  add("pinocchio", r, "jacobian_body", [](Robot& x, const Sample& s) { keep(pin_jacobian_body(x, s.q)); });

  add("chasles", r, "rnea",
      [](Robot& x, const Sample& s) { keep(inverse_dynamics(x.model, x.data, s.q, s.qd, s.qdd)); });
  add("pinocchio", r, "rnea", [](Robot& x, const Sample& s) { keep(pin_rnea(x, s)); });

  add("chasles", r, "mass_matrix", [](Robot& x, const Sample& s) { keep(mass_matrix(x.model, x.data, s.q)); });
  add("pinocchio", r, "mass_matrix",
      [](Robot& x, const Sample& s) { keep(pin_crba(x, s.q, pinocchio::Convention::LOCAL)); });
  add("pinocchio", r, "mass_matrix.world",
      [](Robot& x, const Sample& s) { keep(pin_crba(x, s.q, pinocchio::Convention::WORLD)); });

  add("chasles", r, "forward_dynamics",
      [](Robot& x, const Sample& s) { keep(forward_dynamics(x.model, x.data, s.q, s.qd, s.tau)); });
  add("pinocchio", r, "forward_dynamics",
      [](Robot& x, const Sample& s) { keep(pin_aba(x, s, pinocchio::Convention::LOCAL)); });
  add("pinocchio", r, "forward_dynamics.world",
      [](Robot& x, const Sample& s) { keep(pin_aba(x, s, pinocchio::Convention::WORLD)); });
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::AddCustomContext("pinocchio_version", PINOCCHIO_VERSION);
  return chasles::bench::run_comparison(argc, argv,
                                        {"chasles_pinocchio_bench", "Pinocchio", kTolerance,
                                         "chasles_pinocchio_agreement",
                                         "fk, jacobian_body, rnea, mass_matrix, forward_dynamics (crba and aba in "
                                         "both conventions) agree with Pinocchio " PINOCCHIO_VERSION},
                                        check_agreement, register_benchmarks);
}
