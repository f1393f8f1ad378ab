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
//   seeded random table of 256 (q, q̇, q̈, τ), q within the joint limits (the same seed and
//   sampling as chasles_bench), as Eigen vectors both libraries take as they are; every result
//   goes through benchmark::DoNotOptimize.
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

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "chasles/core/dynamics/dynamics.hpp"
#include "chasles/core/kinematics/kinematics.hpp"
#include "chasles/core/model/urdf.hpp"

namespace {

constexpr size_t kTableSize = 256;  // a power of two: the index wraps with a mask
constexpr unsigned kSeed = 20240611;  // chasles_bench's
constexpr int kChecked = 8;         // table entries compared before timing
constexpr double kTolerance = 1e-9;  // relative to the largest entry (at least 1)

struct Sample {
  Eigen::VectorXd q, qd, qdd, tau;
};

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

// Both libraries' models of one robot, their workspaces and output buffers, and the sample table.
struct Robot {
  Robot(std::string robot_name, const std::string& urdf, const std::string& tip);
  Robot(const Robot&) = delete;
  Robot& operator=(const Robot&) = delete;

  const std::string name;
  const chasles::RobotModel model;
  chasles::Data data;

  pinocchio::Model pmodel;
  std::unique_ptr<pinocchio::Data> pdata;
  pinocchio::FrameIndex tip = 0;
  pinocchio::Data::Matrix6x J;  // computeFrameJacobian's output; zeroed once, every column is written

  std::vector<Sample> table;
};

chasles::UrdfOptions tip_options(const std::string& tip) {
  chasles::UrdfOptions options;
  options.tip_link = tip;
  return options;
}

Robot::Robot(std::string robot_name, const std::string& urdf, const std::string& tip_link)
    : name(std::move(robot_name)), model(chasles::load_urdf_file(urdf, tip_options(tip_link))), data(model) {
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

  // The sample table, drawn as chasles_bench draws it: q uniform within the position limits, q̇
  // within the velocity limits, q̈ in ±5 rad/s², τ within half the effort limits.
  std::mt19937_64 rng(kSeed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto finite_or = [](double x, double fallback) { return std::isfinite(x) ? x : fallback; };
  table.resize(kTableSize);
  for (Sample& s : table) {
    s.q.resize(model.dof());
    s.qd.resize(model.dof());
    s.qdd.resize(model.dof());
    s.tau.resize(model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      const chasles::JointLimits& limits = model.joint(i).limits;
      s.q(i) = 0.5 * (limits.lower + limits.upper) + 0.5 * (limits.upper - limits.lower) * unit(rng);
      s.qd(i) = finite_or(limits.velocity, 2.0) * unit(rng);
      s.qdd(i) = 5.0 * unit(rng);
      s.tau(i) = 0.5 * finite_or(limits.effort, 20.0) * unit(rng);
    }
  }
}

// Keeps a result alive: its address escapes into an asm statement that clobbers memory.
template <class T>
void keep(const T& result) {
  const void* p = &result;
  benchmark::DoNotOptimize(p);
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

struct Check {
  std::string failures;
  std::set<std::string> reported;
  double worst = 0.0;

  void compare(const Robot& robot, const char* quantity, int k, const Eigen::MatrixXd& ours,
               const Eigen::MatrixXd& theirs) {
    const double scale = std::max(1.0, theirs.cwiseAbs().maxCoeff());
    const double error = (ours - theirs).cwiseAbs().maxCoeff() / scale;
    worst = std::max(worst, error);
    // Only the first disagreement of each robot and quantity is printed in full.
    if (!(error <= kTolerance) && reported.insert(robot.name + " " + quantity).second) {
      std::ostringstream out;
      out << "  " << robot.name << " " << quantity << " at table entry " << k
          << ": max |chasles - Pinocchio| = " << error * scale << " (scale " << scale << ")\n    chasles:\n"
          << ours << "\n    Pinocchio:\n"
          << theirs << "\n";
      failures += out.str();
    }
  }
};

void check_agreement(Robot& r, Check& check) {
  for (int k = 0; k < kChecked; ++k) {
    const Sample& s = r.table[static_cast<size_t>(k)];

    const chasles::Transform T_sb = chasles::forward_kinematics(r.model, r.data, s.q);
    check.compare(r, "fk", k, T_sb.matrix(), pin_fk(r, s.q).toHomogeneousMatrix());

    const Eigen::MatrixXd J_b = chasles::body_jacobian(r.model, r.data, s.q);
    check.compare(r, "jacobian_body", k, J_b, angular_first(pin_jacobian_body(r, s.q)));

    const Eigen::VectorXd tau = chasles::inverse_dynamics(r.model, r.data, s.q, s.qd, s.qdd);
    check.compare(r, "rnea", k, tau, pin_rnea(r, s));

    const Eigen::MatrixXd M = chasles::mass_matrix(r.model, r.data, s.q);
    const Eigen::VectorXd qdd = chasles::forward_dynamics(r.model, r.data, s.q, s.qd, s.tau);
    for (const pinocchio::Convention convention : kConventions) {
      const bool world = convention == pinocchio::Convention::WORLD;
      Eigen::MatrixXd M_pin = pin_crba(r, s.q, convention);
      M_pin.triangularView<Eigen::StrictlyLower>() = M_pin.transpose();  // crba fills the upper triangle
      check.compare(r, world ? "mass_matrix.world" : "mass_matrix", k, M, M_pin);
      check.compare(r, world ? "forward_dynamics.world" : "forward_dynamics", k, qdd, pin_aba(r, s, convention));
    }
  }
}

// --- the benchmarks -----------------------------------------------------------------------------

// Registers "<library>/<robot>/<quantity>": each iteration runs `compute` on the next table entry.
template <class Compute>
void add(const char* library, Robot& robot, const char* quantity, Compute compute) {
  const std::string name = std::string(library) + "/" + robot.name + "/" + quantity;
  benchmark::RegisterBenchmark(name.c_str(), [&robot, compute](benchmark::State& state) {
    size_t k = 0;
    for (auto _ : state) {
      compute(robot, robot.table[k++ & (kTableSize - 1)]);
    }
  });
}

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
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  // Everything here goes to stderr: stdout is the benchmark report (JSON for tools/bench.sh).
  std::vector<std::unique_ptr<Robot>> robots;
  try {
    const std::string data = CHASLES_BENCH_DATA;
    robots.push_back(std::make_unique<Robot>("ur5", data + "/ur5.urdf", "tool0"));
    robots.push_back(std::make_unique<Robot>("panda", data + "/panda.urdf", "panda_hand"));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chasles_pinocchio_bench: %s\n", e.what());
    return 1;
  }

  Check check;
  for (auto& robot : robots) check_agreement(*robot, check);
  if (!check.failures.empty()) {
    std::fprintf(stderr,
                 "chasles_pinocchio_bench: chasles and Pinocchio disagree (relative tolerance %g), so the "
                 "timings would compare different computations; not running.\n%s",
                 kTolerance, check.failures.c_str());
    return 1;
  }
  std::ostringstream agreed;
  agreed << "fk, jacobian_body, rnea, mass_matrix, forward_dynamics (crba and aba in both conventions) agree with Pinocchio " << PINOCCHIO_VERSION
         << " on " << kChecked << " configurations per robot; worst relative difference " << check.worst;
  std::fprintf(stderr, "chasles_pinocchio_bench: %s\n", agreed.str().c_str());
  benchmark::AddCustomContext("pinocchio_version", PINOCCHIO_VERSION);
  benchmark::AddCustomContext("chasles_pinocchio_agreement", agreed.str());
  benchmark::AddCustomContext("sample_table", std::to_string(kTableSize) + " entries, seed " + std::to_string(kSeed));

  for (auto& robot : robots) register_benchmarks(*robot);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
