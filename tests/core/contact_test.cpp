// Contact estimation: the momentum balance's terms against the mass matrix and its derivative
// (p = M q̇, Cᵀq̇ = Ṁq̇ − c by central differences of M, g against RNEA), the observer against a
// fine integration with a known external torque (its residual is (1 − e^{−K t}) τ_ext at every
// sample), and the tip wrench against the wrench that made the torque.
#include "core/contact/observer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/decompositions.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

struct Robot {
  std::string name, tip;
};
void PrintTo(const Robot& robot, std::ostream* out) { *out << robot.name; }

class Contact : public ::testing::TestWithParam<Robot> {
 protected:
  void SetUp() override {
    UrdfOptions options;
    options.tip_link = GetParam().tip;
    model_ = std::make_unique<RobotModel>(load_urdf_file(testing::data_path(GetParam().name + ".urdf"), options));
    data_ = std::make_unique<Data>(*model_);
    sample_data_ = std::make_unique<Data>(*model_);
  }
  int n() const { return model_->dof(); }

  // A seeded q in the middle half of each joint's range, and q̇ of order 1.
  void random_state(std::mt19937_64& rng, Eigen::VectorXd& q, Eigen::VectorXd& qd) const {
    std::uniform_real_distribution<double> unit(0.25, 0.75);
    std::normal_distribution<double> normal;
    q.resize(n()), qd.resize(n());
    for (int i = 0; i < n(); ++i) {
      const auto& l = model_->joint(i).limits;
      q(i) = l.lower + (l.upper - l.lower) * unit(rng);
      qd(i) = normal(rng);
    }
  }

  // One step of the true arm under the joint torque tau (held) and viscous damping D, in
  // `substeps` RK4 steps.
  void integrate(Eigen::VectorXd& q, Eigen::VectorXd& qd, const Eigen::VectorXd& tau, const Eigen::VectorXd& damping,
                 double dt, int substeps) {
    auto qdd = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& v) -> Eigen::VectorXd {
      return forward_dynamics(*model_, *data_, x, v, tau - damping.cwiseProduct(v));
    };
    const double h = dt / substeps;
    for (int s = 0; s < substeps; ++s) {
      const Eigen::VectorXd k1q = qd, k1v = qdd(q, k1q);
      const Eigen::VectorXd k2q = qd + 0.5 * h * k1v, k2v = qdd(q + 0.5 * h * k1q, k2q);
      const Eigen::VectorXd k3q = qd + 0.5 * h * k2v, k3v = qdd(q + 0.5 * h * k2q, k3q);
      const Eigen::VectorXd k4q = qd + h * k3v, k4v = qdd(q + h * k3q, k4q);
      q += h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
      qd += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
  }

  // The observer's input at a sample: p, Cᵀq̇ and g in a Data of its own.
  const Data& sample(const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    momentum_terms(*model_, *sample_data_, q, qd);
    return *sample_data_;
  }

  std::unique_ptr<RobotModel> model_;
  std::unique_ptr<Data> data_, sample_data_;
};

TEST_P(Contact, MomentumTermsAreMqdTheTransposedCoriolisTermAndGravity) {
  std::mt19937_64 rng(11);
  Eigen::VectorXd q, qd;
  for (int trial = 0; trial < 20; ++trial) {
    random_state(rng, q, qd);
    const Eigen::MatrixXd M = mass_matrix(*model_, *data_, q);
    const Eigen::VectorXd c = velocity_product(*model_, *data_, q, qd);
    const Eigen::VectorXd g = gravity_torques(*model_, *data_, q);
    // Ṁ along q̇ by central differences; Ṁ = C + Cᵀ, so Cᵀq̇ = Ṁq̇ − Cq̇.
    const double h = 1e-6;
    const Eigen::VectorXd q_plus = q + h * qd, q_minus = q - h * qd;
    const Eigen::MatrixXd M_plus = mass_matrix(*model_, *data_, q_plus);
    const Eigen::MatrixXd M_minus = mass_matrix(*model_, *data_, q_minus);
    const Eigen::VectorXd ct_qd = (M_plus - M_minus) / (2.0 * h) * qd - c;

    const Eigen::VectorXd p = momentum_terms(*model_, *data_, q, qd);
    const double scale = 1.0 + M.norm() * (1.0 + qd.squaredNorm());
    EXPECT_LT((p - M * qd).norm(), 1e-12 * scale) << "trial " << trial;
    EXPECT_LT((data_->ct_qd - ct_qd).norm(), 1e-6 * scale) << "trial " << trial;
    EXPECT_LT((data_->g - g).norm(), 1e-12 * (1.0 + g.norm())) << "trial " << trial;
  }
}

// The arm moves under a PD torque (held over each 1 ms step) and a constant external joint torque
// it is not told about; some samples are lost (dt = 2 ms). The exact solution of ṙ = K(τ_ext − r)
// from r = 0 is (1 − e^{−K t}) τ_ext.
TEST_P(Contact, ResidualFollowsTheFirstOrderLagOfTheExternalTorque) {
  std::mt19937_64 rng(5);
  Eigen::VectorXd q, qd;
  random_state(rng, q, qd);
  qd *= 0.5;
  const Eigen::VectorXd q_goal = q + 0.3 * Eigen::VectorXd::Ones(n());
  Eigen::VectorXd tau_ext(n());
  // Of the size that accelerates each joint by about 1 rad/s², whatever the arm's scale.
  const Eigen::VectorXd M_diagonal = mass_matrix(*model_, *data_, q).diagonal();
  for (int i = 0; i < n(); ++i) tau_ext(i) = (0.5 + 0.25 * i) * M_diagonal(i);
  const Eigen::VectorXd damping = 0.3 * M_diagonal;  // velocity time constants of about 3 s
  const Eigen::VectorXd gain = Eigen::VectorXd::Constant(n(), 40.0);
  MomentumObserver observer(*model_, gain, damping);
  observer.reset(sample(q, qd), qd);

  const double T = 1e-3;
  double t = 0.0, worst = 0.0, sample_dt = 0.0;
  // The PD torque is decided from each sample the controller sees and held until the next.
  auto pd = [&] {
    const Eigen::VectorXd qdd = 20.0 * (q_goal - q) - 5.0 * qd;
    return Eigen::VectorXd(inverse_dynamics(*model_, *data_, q, qd, qdd));
  };
  Eigen::VectorXd tau = pd();
  for (int k = 1; k <= 400; ++k) {
    integrate(q, qd, tau + tau_ext, damping, T, 8);
    t += T, sample_dt += T;
    if (k % 7 == 3) continue;  // a lost sample: the controller holds its torque another step
    observer.update(sample(q, qd), qd, tau, sample_dt);
    sample_dt = 0.0;
    const Eigen::VectorXd expected = (1.0 - std::exp(-40.0 * t)) * tau_ext;
    worst = std::max(worst, (observer.external_torque() - expected).cwiseAbs().maxCoeff());
    tau = pd();
  }
  // What is left is the trapezoid rule's on the smooth terms over each step.
  const double tolerance = 1e-4 * tau_ext.cwiseAbs().maxCoeff();
  EXPECT_LT(worst, tolerance) << "the residual strays from the lag of τ_ext";
  EXPECT_LT((observer.external_torque() - tau_ext).cwiseAbs().maxCoeff(), tolerance);
}

// Known Coulomb friction is the model's: an observer that is not told of f_c reads the friction
// torque as external (−f_c tanh(q̇ / v_c), against the motion), one told of it does not; they differ
// by the lag of f_c tanh(q̇ / v_c) by the same trapezoid — the recursion written out here, sample by
// sample, on an arbitrary motion.
TEST_P(Contact, KnownCoulombFrictionIsTheModels) {
  std::mt19937_64 rng(13);
  Eigen::VectorXd q, qd;
  random_state(rng, q, qd);
  const Eigen::VectorXd gain = Eigen::VectorXd::Constant(n(), 40.0);
  const Eigen::VectorXd coulomb = Eigen::VectorXd::LinSpaced(n(), 0.5, 0.1);
  MomentumObserver with(*model_, gain, {}, coulomb), without(*model_, gain);
  with.reset(sample(q, qd), qd);
  without.reset(sample(q, qd), qd);
  const auto friction = [&](const Eigen::VectorXd& v) {
    return Eigen::VectorXd(coulomb.array() * (v.array() / kCoulombVelocity).tanh());
  };
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(n()), f_before = friction(qd);
  const Eigen::VectorXd tau = Eigen::VectorXd::LinSpaced(n(), -2.0, 3.0);
  const double dt = 1e-3, a = std::exp(-40.0 * dt);
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    q += dt * qd;
    qd = 0.3 * Eigen::VectorXd::LinSpaced(n(), 1.0, -1.0) * std::sin(0.05 * k);  // through zero and back
    with.update(sample(q, qd), qd, tau, dt);
    without.update(sample(q, qd), qd, tau, dt);
    const Eigen::VectorXd f = friction(qd);
    expected = a * expected + (1.0 - a) * 0.5 * (f_before + f);
    f_before = f;
    worst = std::max(worst, (with.external_torque() - without.external_torque() - expected).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(expected.cwiseAbs().maxCoeff(), 0.1) << "the friction must have been felt";
  EXPECT_LT(worst, 1e-12);
  EXPECT_THROW(MomentumObserver(*model_, gain, {}, -coulomb), ObserverError);
}

// A constant wrench at the tip of an arm held still: the residual converges to J_bᵀ F and the tip
// wrench recovers F (in the tip frame and base-aligned) where the joints can feel it.
TEST_P(Contact, TipWrenchRecoversThePushOnAnArmAtRest) {
  std::mt19937_64 rng(9);
  Eigen::VectorXd q, qd;
  // A configuration away from singularities (the damped directions are tested on their own).
  for (int attempt = 0; attempt < 100; ++attempt) {
    random_state(rng, q, qd);
    Eigen::JacobiSVD<Matrix6Xd> svd(body_jacobian(*model_, *data_, q));
    if (n() < 6 || svd.singularValues()(5) > 2.0 * WrenchDamping{}.threshold) break;
  }
  qd.setZero();
  const Matrix6Xd J_b = body_jacobian(*model_, *data_, q);
  const Transform T_sb = data_->T_sb;
  Vector6d F_base;
  F_base << 0.5, -0.3, 0.2, 12.0, -5.0, 20.0;  // (m, f) base-aligned at the tip origin
  Vector6d F_tip;
  F_tip << T_sb.linear().transpose() * F_base.head<3>(), T_sb.linear().transpose() * F_base.tail<3>();
  const Eigen::VectorXd tau_ext = J_b.transpose() * F_tip;

  MomentumObserver observer(*model_, Eigen::VectorXd::Constant(n(), 50.0));
  observer.reset(sample(q, qd), qd);
  const Eigen::VectorXd g = gravity_torques(*model_, *data_, q);
  for (int k = 0; k < 1000; ++k) {
    // Held by g − τ_ext: the arm stays where it is, so the estimate is the lag of τ_ext alone.
    const Eigen::VectorXd tau = g - tau_ext;
    Eigen::VectorXd q_next = q, qd_next = qd;
    integrate(q_next, qd_next, tau + tau_ext, Eigen::VectorXd::Zero(n()), 1e-3, 1);
    ASSERT_LT((q_next - q).norm(), 1e-12);
    observer.update(sample(q_next, qd_next), qd_next, tau, 1e-3);
  }
  const Eigen::VectorXd& r = observer.external_torque();
  EXPECT_LT((r - tau_ext).norm(), 1e-9 * (1.0 + tau_ext.norm()));  // e^{−50} of the way left

  const Vector6d F_hat = tip_wrench_from_torque(J_b, r);
  if (n() >= 6) {
    Eigen::JacobiSVD<Matrix6Xd> svd(J_b);
    ASSERT_GT(svd.singularValues()(5), WrenchDamping{}.threshold) << "pick a configuration away from singularities";
    EXPECT_LT((F_hat - F_tip).norm(), 1e-8);
    EXPECT_LT((base_aligned_wrench(T_sb, F_hat) - F_base).norm(), 1e-8);
  } else {
    // Fewer joints than wrench directions: the estimate explains the torque exactly, with the
    // least wrench that does.
    EXPECT_LT((J_b.transpose() * F_hat - tau_ext).norm(), 1e-8 * (1.0 + tau_ext.norm()));
    EXPECT_LE(F_hat.norm(), F_tip.norm() + 1e-9);
  }
}

TEST_P(Contact, ObserverAndWrenchAllocateNothing) {
  Eigen::VectorXd q, qd;
  std::mt19937_64 rng(2);
  random_state(rng, q, qd);
  MomentumObserver observer(*model_, Eigen::VectorXd::Constant(n(), 30.0));
  observer.reset(sample(q, qd), qd);
  const Eigen::VectorXd tau = Eigen::VectorXd::Ones(n());
  body_jacobian(*model_, *data_, q);
  Vector6d F = Vector6d::Zero();
  {
    testing::AllocationCounter counter;
    observer.update(sample(q, qd), qd, tau, 1e-3);
    F = tip_wrench_from_torque(data_->J_b, observer.external_torque());
    EXPECT_EQ(counter.count(), 0);
  }
  EXPECT_TRUE(F.allFinite());
}

INSTANTIATE_TEST_SUITE_P(Robots, Contact,
                         ::testing::Values(Robot{"ur5", "tool0"}, Robot{"panda", "panda_hand"},
                                           Robot{"tiago", "hand_grasping_frame"}, Robot{"finger_edu", "finger_tip_link"},
                                           Robot{"iiwa14", "iiwa_link_ee"}),
                         [](const ::testing::TestParamInfo<Robot>& p) { return p.param.name; });

// At a singularity the least-squares wrench would be unbounded; the damped one is not, and it
// still explains the torque the joints can feel.
TEST(ContactWrench, StaysBoundedAtASingularity) {
  const RobotModel model = load_urdf_file(testing::data_path("ur5.urdf"), UrdfOptions{"tool0"});
  Data data(model);
  // UR5 at q = 0: the arm stretched out, wrist axes aligned.
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  const Matrix6Xd J_b = body_jacobian(model, data, q);
  Eigen::JacobiSVD<Matrix6Xd> svd(J_b);
  ASSERT_LT(svd.singularValues()(5), 1e-9);
  const Eigen::VectorXd tau = Eigen::VectorXd::Ones(model.dof());
  const Vector6d F = tip_wrench_from_torque(J_b, tau);
  const WrenchDamping damping;
  EXPECT_LE(F.norm(), tau.norm() / (2.0 * damping.lambda_max));
  EXPECT_TRUE(F.allFinite());
}

// Against the damped least squares written with J_b's SVD, J_b = U Σ Vᵀ: F = Σ u_k σ_k (v_kᵀ τ) /
// (σ_k² + λ²(σ_k)), on configurations from far to very near the stretched-out singularity, so both
// the certified undamped path and the damped one are taken.
TEST(ContactWrench, EqualsTheDampedLeastSquaresOfTheSvd) {
  const RobotModel model = load_urdf_file(testing::data_path("ur5.urdf"), UrdfOptions{"tool0"});
  Data data(model);
  const WrenchDamping damping;
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal;
  int damped = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Eigen::VectorXd q(model.dof()), tau(model.dof());
    const double scale = std::pow(10.0, -4.0 * trial / 300.0);  // 1 down to 1e-4 rad from q = 0
    for (int i = 0; i < model.dof(); ++i) q(i) = scale * normal(rng), tau(i) = normal(rng);
    const Matrix6Xd J_b = body_jacobian(model, data, q);
    Eigen::JacobiSVD<Matrix6Xd> svd(J_b, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Vector6d expected = Vector6d::Zero();
    for (int k = 0; k < svd.singularValues().size(); ++k) {
      const double sigma = svd.singularValues()(k);
      const double ratio = sigma / damping.threshold;
      const double lambda_sq = ratio < 1.0 ? damping.lambda_max * damping.lambda_max * (1.0 - ratio * ratio) : 0.0;
      damped += lambda_sq > 0.0;
      expected += svd.matrixU().col(k) * sigma * svd.matrixV().col(k).dot(tau) / (sigma * sigma + lambda_sq);
    }
    const Vector6d F = tip_wrench_from_torque(J_b, tau);
    EXPECT_LT((F - expected).norm(), 1e-7 * (1.0 + expected.norm())) << "trial " << trial << ", scale " << scale;
  }
  EXPECT_GT(damped, 10) << "the damped path was not taken";
}

TEST(ContactObserver, RefusesGainsAndDampingThatCannotMakeAnObserver) {
  const RobotModel model = load_urdf_file(testing::data_path("panda.urdf"), UrdfOptions{"panda_hand"});
  const Eigen::VectorXd ok = Eigen::VectorXd::Constant(model.dof(), 10.0);
  EXPECT_THROW(MomentumObserver(model, Eigen::VectorXd::Constant(3, 10.0)), ObserverError);
  EXPECT_THROW(MomentumObserver(model, Eigen::VectorXd::Zero(model.dof())), ObserverError);
  Eigen::VectorXd nan = ok;
  nan(2) = std::nan("");
  EXPECT_THROW(MomentumObserver(model, nan), ObserverError);
  EXPECT_THROW(MomentumObserver(model, ok, -ok), ObserverError);
  EXPECT_NO_THROW(MomentumObserver(model, ok, ok));
}

// A step of no length, a negative one, an infinite one (which made the estimate the last sample's
// mean alone) and NaN (which started the observer again unsaid) are a caller's mistake, refused
// before the observer has started and after.
TEST(ContactObserver, RefusesAStepThatIsNotPositiveAndFinite) {
  const RobotModel model = load_urdf_file(testing::data_path("panda.urdf"), UrdfOptions{"panda_hand"});
  Data data(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Constant(model.dof(), 0.3);
  const Eigen::VectorXd qd = Eigen::VectorXd::Constant(model.dof(), 0.1), tau = Eigen::VectorXd::Ones(model.dof());
  momentum_terms(model, data, q, qd);
  MomentumObserver observer(model, Eigen::VectorXd::Constant(model.dof(), 10.0));
  for (const bool started : {false, true}) {
    if (started) observer.reset(data, qd);
    for (const double dt : {0.0, -1e-3, std::numeric_limits<double>::infinity(), std::nan("")}) {
      EXPECT_THROW(observer.update(data, qd, tau, dt), ArgumentError) << dt;
      EXPECT_EQ(observer.started(), started) << dt;
    }
  }
  EXPECT_NO_THROW(observer.update(data, qd, tau, 1e-3));
  EXPECT_TRUE(observer.external_torque().allFinite());
}

}  // namespace
}  // namespace chasles
