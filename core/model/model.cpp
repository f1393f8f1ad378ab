#include "core/model/model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/lie/se3.hpp"
#include "core/lie/so3.hpp"
#include "core/number_text.hpp"

namespace chasles {

const char* to_string(JointType type) {
  switch (type) {
    case JointType::Revolute: return "revolute";
    case JointType::Continuous: return "continuous";
    case JointType::Prismatic: return "prismatic";
  }
  return "unknown";
}

Matrix6d SpatialInertia::matrix() const {
  Matrix6d G;
  G << I, hat3(h), hat3(h).transpose(), mass * Matrix3d::Identity();
  return G;
}

SpatialInertia SpatialInertia::from_matrix(const Matrix6d& G) {
  return {G(3, 3), vee3(G.topRightCorner<3, 3>()), G.topLeftCorner<3, 3>()};
}

namespace {

bool is_finite(const Transform& T) { return T.matrix().allFinite(); }

bool is_rotation(const Matrix3d& R) {
  constexpr double tolerance = 1e-9;
  return (R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() < tolerance &&
         std::abs(R.determinant() - 1.0) < tolerance;
}

void check(bool ok, const ChainDescription& d, const std::string& what) {
  if (!ok) throw ModelError(d.source + ": " + what);
}

void validate(const ChainDescription& d) {
  check(!d.joints.empty(), d, "no movable joint between '" + d.base_link + "' and '" + d.tip_link + "'");
  check(d.inertia.size() == d.joints.size(), d, "one spatial inertia per body is required");
  check(d.gravity.allFinite(), d, "gravity is not finite");
  check(d.armature.empty() || d.armature.size() == d.joints.size(), d,
        "armature has " + std::to_string(d.armature.size()) + " values; the chain has " +
            std::to_string(d.joints.size()) + " joints (one per joint, or none)");
  check(is_finite(d.T_last_tip) && is_rotation(d.T_last_tip.linear()), d, "tip offset is not a rigid transform");
  for (size_t i = 0; i < d.joints.size(); ++i) {
    const Joint& j = d.joints[i];
    const std::string where = "joint '" + j.name + "': ";
    check(is_finite(j.T_parent_joint) && is_rotation(j.T_parent_joint.linear()), d,
          where + "origin is not a finite rigid transform");
    check(j.axis.allFinite() && std::abs(j.axis.norm() - 1.0) < 1e-12, d, where + "axis is not a unit vector");
    const JointLimits& l = j.limits;
    check(std::isfinite(l.lower) && std::isfinite(l.upper), d, where + "position limits are not finite");
    check(l.lower <= l.upper, d, where + "lower limit is above the upper limit");
    check(l.velocity > 0.0, d, where + "velocity limit is not positive (+inf: none)");
    check(l.effort > 0.0, d, where + "effort limit is not positive (+inf: none)");
    if (!d.armature.empty()) {
      const double a = d.armature[i];
      check(std::isfinite(a) && a >= 0.0, d,
            where + "armature " + number_text(a) + " is not a finite value >= 0 (" +
                (j.type == JointType::Prismatic ? "kg" : "kg*m^2") + ", the rotor's reflected inertia)");
    }
    const Matrix6d& G = d.inertia[i];
    check(G.allFinite() && (G - G.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * (1.0 + G.cwiseAbs().maxCoeff()), d,
          "body of joint '" + j.name + "': spatial inertia is not finite and symmetric");
  }
  for (const ChainLink& link : d.links) {
    check(link.body >= 0 && link.body <= static_cast<int>(d.joints.size()) && is_finite(link.T_body_link), d,
          "link '" + link.name + "': invalid placement");
  }
}

// A revolute joint whose axis is exactly ±e_k (two zero entries, the third ±1) gets kind k; the
// specialised path then computes the same products as the general one, only without the zeros.
JointAxis classify_axis(const Joint& joint) {
  if (joint.type == JointType::Prismatic) return {};
  for (int k = 0; k < 3; ++k) {
    const double a = joint.axis(k);
    if ((a == 1.0 || a == -1.0) && joint.axis((k + 1) % 3) == 0.0 && joint.axis((k + 2) % 3) == 0.0) {
      return {static_cast<AxisKind>(k), a};
    }
  }
  return {};
}

// A rotation whose row and column k are exactly e_k and whose other 2×2 block is exactly
// [[c, −s], [s, c]] is a rotation about e_k (the identity when c = 1, s = 0): its products with it
// are then the general ones without the terms that are exactly zero. With s = ±1 and |c| ≤ 4ε it is
// a quarter turn, c rounded to 0 (PlacementKind's comment says why); R is then made that exactly,
// so that every path, special or general, takes the same placement.
PlacementRotation classify_placement(Matrix3d& R) {
  constexpr double kRounding = 4.0 * std::numeric_limits<double>::epsilon();
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    if (R(k, k) == 1.0 && R(k, i) == 0.0 && R(k, j) == 0.0 && R(i, k) == 0.0 && R(j, k) == 0.0 &&
        R(i, i) == R(j, j) && R(i, j) == -R(j, i)) {
      if (R(i, i) == 1.0 && R(j, i) == 0.0) return {PlacementKind::Identity, 1.0, 0.0};
      if (std::abs(R(j, i)) == 1.0 && std::abs(R(i, i)) <= kRounding) {
        R(i, i) = R(j, j) = 0.0;
        return {static_cast<PlacementKind>(static_cast<int>(PlacementKind::QuarterX) + k), 0.0, R(j, i)};
      }
      return {static_cast<PlacementKind>(k), R(i, i), R(j, i)};
    }
  }
  return {};
}

}  // namespace

RobotModel::RobotModel(ChainDescription description) : d_(std::move(description)) {
  validate(d_);
  dof_ = static_cast<int>(d_.joints.size());
  const int n = dof_;
  if (d_.armature.empty()) d_.armature.assign(static_cast<size_t>(n), 0.0);
  armature_ = Eigen::Map<const Eigen::VectorXd>(d_.armature.data(), n);
  M_body_.resize(static_cast<size_t>(n));
  A_.resize(static_cast<size_t>(n));
  axis_kind_.resize(static_cast<size_t>(n));
  placement_.resize(static_cast<size_t>(n));
  G_.resize(static_cast<size_t>(n));
  S_.resize(6, n);
  B_.resize(6, n);
  Transform M_i = Transform::Identity();
  for (int i = 0; i < n; ++i) {
    placement_[static_cast<size_t>(i)] = classify_placement(d_.joints[static_cast<size_t>(i)].T_parent_joint.linear());
    const Joint& j = joint(i);
    M_i = M_i * j.T_parent_joint;
    M_body_[static_cast<size_t>(i)] = M_i;
    Vector6d& A = A_[static_cast<size_t>(i)];
    if (j.type == JointType::Prismatic) {
      A << Vector3d::Zero(), j.axis;
    } else {
      A << j.axis, Vector3d::Zero();
    }
    axis_kind_[static_cast<size_t>(i)] = classify_axis(j);
    S_.col(i) = adjoint_times(M_i, A);  // S_i = [Ad_{M_i}] A_i
    G_[static_cast<size_t>(i)] = SpatialInertia::from_matrix(d_.inertia[static_cast<size_t>(i)]);
  }
  M_ = M_i * d_.T_last_tip;
  for (int i = 0; i < n; ++i) B_.col(i) = adjoint_inverse_times(M_, S_.col(i));
}

RobotModel with_armature(const RobotModel& model, const Eigen::VectorXd& armature) {
  ChainDescription description = model.description();
  if (armature.size() != model.dof()) {
    throw ModelError(description.source + ": armature has " + std::to_string(armature.size()) +
                     " values; the chain has " + std::to_string(model.dof()) + " joints (one per joint)");
  }
  description.armature.assign(armature.data(), armature.data() + armature.size());
  return RobotModel(std::move(description));
}

int RobotModel::joint_index(const std::string& name) const {
  for (int i = 0; i < dof(); ++i) {
    if (joint(i).name == name) return i;
  }
  return -1;
}

bool RobotModel::check(const Data& data) const {
  const auto bodies = static_cast<size_t>(dof()) + 1;
  return data.T_local.size() == bodies && data.sin_q.size() == dof() && data.cos_q.size() == dof() &&
         data.T_body.size() == bodies && data.V.size() == bodies &&
         data.Vd.size() == bodies && data.F.size() == bodies && data.crb_column.size() == bodies &&
         data.T_link.size() == links().size() && data.J_s.cols() == dof() && data.J_b.cols() == dof() &&
         data.M.rows() == dof() && data.M.cols() == dof() && data.tau.size() == dof() && data.g.size() == dof() &&
         data.c.size() == dof() && data.qdd.size() == dof() && data.p.size() == dof() &&
         data.ct_qd.size() == dof() && data.bias.size() == dof();
}

Data::Data(const RobotModel& model)
    : T_local(static_cast<size_t>(model.dof()) + 1, Transform::Identity()),
      sin_q(Eigen::VectorXd::Zero(model.dof())),
      cos_q(Eigen::VectorXd::Ones(model.dof())),
      T_body(static_cast<size_t>(model.dof()) + 1, Transform::Identity()),
      T_sb(Transform::Identity()),
      T_link(model.links().size(), Transform::Identity()),
      J_s(Matrix6Xd::Zero(6, model.dof())),
      J_b(Matrix6Xd::Zero(6, model.dof())),
      V(static_cast<size_t>(model.dof()) + 1, Vector6d::Zero()),
      Vd(static_cast<size_t>(model.dof()) + 1, Vector6d::Zero()),
      F(static_cast<size_t>(model.dof()) + 1, Vector6d::Zero()),
      crb_column(static_cast<size_t>(model.dof()) + 1, Vector6d::Zero()),
      tau(Eigen::VectorXd::Zero(model.dof())),
      g(Eigen::VectorXd::Zero(model.dof())),
      c(Eigen::VectorXd::Zero(model.dof())),
      M(Eigen::MatrixXd::Zero(model.dof(), model.dof())),
      qdd(Eigen::VectorXd::Zero(model.dof())),
      p(Eigen::VectorXd::Zero(model.dof())),
      ct_qd(Eigen::VectorXd::Zero(model.dof())),
      bias(Eigen::VectorXd::Zero(model.dof())),
      M_llt(model.dof()) {}

namespace {

// Eigen's LLT::compute with its unblocked in-place factorisation written out for small n: the same
// operations column by column (x = M_kk − |L_k,0:k|², L_kk = √x, then the column below divided by
// it), reading only the lower triangle of L (= M on entry) and leaving the upper one as it was.
// N is n when known at compile time (the loops then unroll), else Eigen::Dynamic. Returns M's L1
// norm (its largest absolute column sum, from the lower triangle as Eigen computes it) and whether
// every pivot was positive.
template <int N>
bool cholesky_in_place(double* data, Eigen::Index size, double& l1_norm) {
  Eigen::Map<Eigen::Matrix<double, N, N>> L(data, size, size);
  const Eigen::Index n = N == Eigen::Dynamic ? size : N;
  l1_norm = 0.0;
  for (Eigen::Index j = 0; j < n; ++j) {
    double sum = 0.0;
    for (Eigen::Index i = 0; i < j; ++i) sum += std::abs(L(j, i));
    for (Eigen::Index i = j; i < n; ++i) sum += std::abs(L(i, j));
    l1_norm = std::max(l1_norm, sum);
  }
  for (Eigen::Index k = 0; k < n; ++k) {
    double x = L(k, k);
    for (Eigen::Index j = 0; j < k; ++j) x -= L(k, j) * L(k, j);
    if (!(x > 0.0)) return false;
    const double pivot = std::sqrt(x);
    L(k, k) = pivot;
    for (Eigen::Index i = k + 1; i < n; ++i) {
      double sum = L(i, k);
      for (Eigen::Index j = 0; j < k; ++j) sum -= L(i, j) * L(k, j);
      L(i, k) = sum / pivot;
    }
  }
  return true;
}

}  // namespace

void CholeskyFactor::factorize(const Eigen::MatrixXd& M) {
  m_matrix = M;  // same size: no allocation
  const Eigen::Index n = M.rows();
  bool ok = false;
  switch (n) {  // the arms' sizes, unrolled
    case 6: ok = cholesky_in_place<6>(m_matrix.data(), n, m_l1_norm); break;
    case 7: ok = cholesky_in_place<7>(m_matrix.data(), n, m_l1_norm); break;
    default: ok = cholesky_in_place<Eigen::Dynamic>(m_matrix.data(), n, m_l1_norm); break;
  }
  m_isInitialized = true;
  m_info = ok ? Eigen::Success : Eigen::NumericalIssue;
}

}  // namespace chasles
