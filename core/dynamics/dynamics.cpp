#include "chasles/core/dynamics/dynamics.hpp"

#include <cmath>
#include <limits>

#include "chasles/core/lie/se3.hpp"
#include "chasles/core/lie/sincos.hpp"
#include "chasles/core/model/joint_axis.hpp"

namespace chasles {
namespace {

size_t body(int joint_index) { return static_cast<size_t>(joint_index) + 1; }

// A_iᵀ F: joint i's share of a wrench; one entry of F for an axis-aligned revolute joint.
CHASLES_ALWAYS_INLINE double axis_dot(const RobotModel& model, int i, const Vector6d& F) {
  const JointAxis& a = model.joint_axis(i);
  return a.kind != AxisKind::General ? a.sign * F(static_cast<int>(a.kind)) : model.local_axis(i).dot(F);
}

// [Ad_{T⁻¹}]ᵀ F = (R m + p × R f, R f), as lie/se3.hpp's adjoint_inverse_transpose_times, with R m
// and R f side by side (entry k of each in one SSE2 register, as lie/sincos.hpp's vector
// extensions): fewer instructions, which is what the backward passes of RNEA wait for (4–7 % of
// inverse dynamics). The moment then also waits for R f's lane to be taken out, a longer chain of
// dependent operations: the CRBA's columns, which are such chains and little else, keep the plain one.
CHASLES_ALWAYS_INLINE Vector6d wrench_to_parent(const Transform& T, const Vector6d& F) {
  using detail::Double2;
  const Matrix3d& R = T.linear();
  const Double2 x[3] = {{F(0), F(3)}, {F(1), F(4)}, {F(2), F(5)}};
  Double2 y[3];
  for (int k = 0; k < 3; ++k) y[k] = R(k, 0) * x[0] + R(k, 1) * x[1] + R(k, 2) * x[2];
  const Vector3d& p = T.translation();
  Vector6d out;
  out << y[0][0] + (p(1) * y[2][1] - p(2) * y[1][1]), y[1][0] + (p(2) * y[0][1] - p(0) * y[2][1]),
      y[2][0] + (p(0) * y[1][1] - p(1) * y[0][1]), y[0][1], y[1][1], y[2][1];
  return out;
}

// G A and G B side by side, entry k of A in one lane of an SSE2 register and of B in the other:
// the two products the backward passes take of each body's inertia (G V and G V̇), one pass of
// 2-wide arithmetic for both (inverse dynamics 7 % faster).
CHASLES_ALWAYS_INLINE void inertia_times_both(const SpatialInertia& G, const Vector6d& A, const Vector6d& B,
                                              Vector6d& GA, Vector6d& GB) {
  using detail::Double2;
  const Double2 w[3] = {{A(0), B(0)}, {A(1), B(1)}, {A(2), B(2)}};
  const Double2 v[3] = {{A(3), B(3)}, {A(4), B(4)}, {A(5), B(5)}};
  const Vector3d& h = G.h;
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    const Double2 moment = G.I(k, 0) * w[0] + G.I(k, 1) * w[1] + G.I(k, 2) * w[2] + (h(i) * v[j] - h(j) * v[i]);
    const Double2 force = G.mass * v[k] - (h(i) * w[j] - h(j) * w[i]);
    GA(k) = moment[0];
    GB(k) = moment[1];
    GA(3 + k) = force[0];
    GB(3 + k) = force[1];
  }
}

// RNEA (MR eq. 8.50–8.53) with the terms that are zero left out at compile time. Gravity enters
// as a base acceleration V̇_0 = (0, −g). Expects data.T_local to be current.
template <bool kVelocity, bool kAcceleration>
CHASLES_FLATTEN void rnea(const RobotModel& model, Data& data, const double* qd, const double* qdd,
                          const Vector3d& gravity, const Vector6d& F_tip, Eigen::VectorXd& tau) {
  const int n = model.dof();
  data.Vd[0] << Vector3d::Zero(), -gravity;
  for (int i = 0; i < n; ++i) {
    const Transform& T = data.T_local[body(i)];
    Vector6d& Vd = data.Vd[body(i)];
    Vd = adjoint_inverse_times(T, data.Vd[body(i) - 1]);
    visit_axis(model, i, [&](auto axis) {
      if constexpr (kVelocity) {
        Vector6d& V = data.V[body(i)];
        V = adjoint_inverse_times(T, data.V[body(i) - 1]) + axis.times(qd[i]);
        Vd += axis.ad_times(V, qd[i]);
      }
      if constexpr (kAcceleration) Vd += axis.times(qdd[i]);
    });
  }
  // A zero tip wrench (the common call) needs no transform.
  Vector6d F = Vector6d::Zero();
  if (!(F_tip.array() == 0.0).all()) F = adjoint_inverse_transpose_times(model.T_last_tip(), F_tip);
  for (int i = n - 1; i >= 0; --i) {
    const SpatialInertia& G = model.body_inertia(i);
    if constexpr (kVelocity) {
      const Vector6d& V = data.V[body(i)];
      Vector6d GVd, GV;
      inertia_times_both(G, data.Vd[body(i)], V, GVd, GV);
      F += GVd - ad_transpose_times(V, GV);
    } else {
      F += G * data.Vd[body(i)];
    }
    data.F[body(i)] = F;
    tau(i) = axis_dot(model, i, F);
    // The rotor's reflected inertia, on the joint alone (M's diagonal; see mass_matrix_from_composites).
    if constexpr (kAcceleration) tau(i) += model.armature()[i] * qdd[i];
    if (i > 0) F = wrench_to_parent(data.T_local[body(i)], F);  // the base's is unused
  }
}

// The composite inertia of body i expressed in the frame of its parent, T = T_{i−1,i}
// (Featherstone's inertia transform, in (m, h, I) form): h' = R h + m p and
// I' = R I Rᵀ − [h][p] − [p][h] − m[p]², with h = R h; since [a][b] = b aᵀ − (a·b)1 the last three
// terms are −p h'ᵀ − h pᵀ + p·(h + h') 1, outer products instead of 3×3 products.
CHASLES_ALWAYS_INLINE SpatialInertia to_parent(const Transform& T, const SpatialInertia& G) {
  const Matrix3d& R = T.linear();
  const Vector3d& p = T.translation();
  SpatialInertia out;
  out.mass = G.mass;
  const Vector3d h = R * G.h;
  out.h = h + G.mass * p;
  const Matrix3d RI = R * G.I;
  out.I.noalias() = RI * R.transpose();
  out.I.noalias() -= p * out.h.transpose();
  out.I.noalias() -= h * p.transpose();
  out.I.diagonal().array() += p.dot(h + out.h);
  return out;
}

void add(SpatialInertia& a, const SpatialInertia& b) {
  a.mass += b.mass;
  a.h += b.h;
  a.I += b.I;
}

// G A_i: the momentum of a body moving with unit rate about joint i, (I a, a × h) for a revolute
// joint (MR eq. 8.32 with v = 0): a column of I and two entries of h for an axis-aligned one.
template <int K>
CHASLES_ALWAYS_INLINE Vector6d inertia_times_axis(const SpatialInertia& G, const Joint&, AlignedRevoluteAxis<K> a) {
  constexpr int I = AlignedRevoluteAxis<K>::I, J = AlignedRevoluteAxis<K>::J;
  Vector6d P;
  P.head<3>() = a.sign * G.I.col(K);
  P(3 + I) = -a.sign * G.h(J);
  P(3 + J) = a.sign * G.h(I);
  P(3 + K) = 0.0;
  return P;
}

CHASLES_ALWAYS_INLINE Vector6d inertia_times_axis(const SpatialInertia& G, const Joint& joint, GeneralAxis) {
  const Vector3d& a = joint.axis;
  Vector6d P;
  if (joint.type == JointType::Prismatic) {
    P << G.h.cross(a), G.mass * a;
  } else {
    P << G.I * a, a.cross(G.h);
  }
  return P;
}

// The composite inertia C_i of bodies i…n in body i's frame, tip to base (MR §8.4, Featherstone's
// CRBA): C_i = G_i + C_{i+1} carried into frame i. Expects data.T_local to be current.
void composite_inertias(const RobotModel& model, Data& data) {
  const int n = model.dof();
  data.composite[body(n - 1)] = model.body_inertia(n - 1);
  for (int i = n - 1; i > 0; --i) {
    data.composite[body(i - 1)] = model.body_inertia(i - 1);
    add(data.composite[body(i - 1)], to_parent(data.T_local[body(i)], data.composite[body(i)]));
  }
}

// M from the composite inertias in data.composite: column i is the wrench that accelerates joint i
// alone, carried down toward the base. The one place M is assembled, so the armature is added here
// (to the diagonal: a rotor turns with its own joint only) and no caller can leave it out.
CHASLES_FLATTEN void mass_matrix_from_composites(const RobotModel& model, Data& data) {
  for (int i = 0; i < model.dof(); ++i) {
    Vector6d F = visit_axis(model, i, [&](auto axis) {
      return inertia_times_axis(data.composite[body(i)], model.joint(i), axis);
    });
    data.M(i, i) = axis_dot(model, i, F) + model.armature()[i];
    for (int j = i; j > 0; --j) {
      F = adjoint_inverse_transpose_times(data.T_local[body(j)], F);
      data.M(j - 1, i) = data.M(i, j - 1) = axis_dot(model, j - 1, F);
    }
  }
}

// The largest Cholesky pivot of M that is still rounding: n ε max_i M_ii.
double singular_pivot(const Eigen::MatrixXd& M) {
  return static_cast<double>(M.rows()) * std::numeric_limits<double>::epsilon() * M.diagonal().cwiseAbs().maxCoeff();
}

// x ← (L Lᵀ)⁻¹ x by forward then back substitution on the lower factor L, by hand: at n = 6 or 7
// Eigen's dynamic-size triangular solves spend more in dispatch and blocking than in their n² flops.
// Each pivot's reciprocal does not wait for the substitution, so only a product stays on its chain
// of dependent entries, not a division.
void cholesky_solve_in_place(const Eigen::MatrixXd& L, Eigen::VectorXd& x) {
  const Eigen::Index n = L.rows();
  for (Eigen::Index i = 0; i < n; ++i) {  // L y = x
    double sum = x(i);
    for (Eigen::Index k = 0; k < i; ++k) sum -= L(i, k) * x(k);
    x(i) = sum * (1.0 / L(i, i));
  }
  for (Eigen::Index i = n - 1; i >= 0; --i) {  // Lᵀ x = y
    double sum = x(i);
    for (Eigen::Index k = i + 1; k < n; ++k) sum -= L(k, i) * x(k);
    x(i) = sum * (1.0 / L(i, i));
  }
}

}  // namespace

const Eigen::VectorXd& inverse_dynamics(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd, const JointVector& qdd, const Vector6d& F_tip) {
  check_joint_vector(model, qd, "qd");
  check_joint_vector(model, qdd, "qdd");
  local_transforms(model, data, q);
  rnea<true, true>(model, data, qd.data(), qdd.data(), model.gravity(), F_tip, data.tau);
  return data.tau;
}

const Eigen::VectorXd& gravity_torques(const RobotModel& model, Data& data, const JointVector& q) {
  local_transforms(model, data, q);
  rnea<false, false>(model, data, nullptr, nullptr, model.gravity(), Vector6d::Zero(), data.g);
  return data.g;
}

const Eigen::VectorXd& velocity_product(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd) {
  check_joint_vector(model, qd, "qd");
  local_transforms(model, data, q);
  rnea<true, false>(model, data, qd.data(), nullptr, Vector3d::Zero(), Vector6d::Zero(), data.c);
  return data.c;
}

CHASLES_FLATTEN const Eigen::VectorXd& momentum_terms(const RobotModel& model, Data& data, const JointVector& q,
                                                      const JointVector& qd) {
  check_joint_vector(model, qd, "qd");
  local_transforms(model, data, q);
  const int n = model.dof();
  // Forward: body twists V_i and the gravity each body feels, as the base acceleration (0, −g)
  // seen from body i (the V̇_i of a chain at rest).
  data.Vd[0] << Vector3d::Zero(), -model.gravity();
  for (int i = 0; i < n; ++i) {
    const Transform& T = data.T_local[body(i)];
    data.V[body(i)] = adjoint_inverse_times(T, data.V[body(i) - 1]) +
                      visit_axis(model, i, [&](auto axis) { return axis.times(qd(i)); });
    data.Vd[body(i)] = adjoint_inverse_times(T, data.Vd[body(i) - 1]);
  }
  // Backward: subtree momentum H and gravity wrench W, carried toward the base as wrenches are.
  Vector6d H = Vector6d::Zero(), W = Vector6d::Zero();
  for (int i = n - 1; i >= 0; --i) {
    const Vector6d& V = data.V[body(i)];
    Vector6d GV, GVd;
    inertia_times_both(model.body_inertia(i), V, data.Vd[body(i)], GV, GVd);
    H += GV;
    W += GVd;
    data.p(i) = axis_dot(model, i, H) + model.armature()[i] * qd(i);  // (M + diag(armature)) q̇
    data.ct_qd(i) = axis_dot(model, i, ad_transpose_times(V, H));
    data.g(i) = axis_dot(model, i, W);
    H = wrench_to_parent(data.T_local[body(i)], H);
    W = wrench_to_parent(data.T_local[body(i)], W);
  }
  return data.p;
}

CHASLES_FLATTEN const Data& compute_tick_terms(const RobotModel& model, Data& data, const JointVector& q,
                                               const JointVector& qd) {
  check_joint_vector(model, qd, "qd");
  local_transforms(model, data, q);
  const int n = model.dof();
  // Forward: body poses and twists, and the acceleration each body has at q̈ = 0 — the velocity
  // product's plus gravity's, entered as the base acceleration (0, −g) (MR eq. 8.50–8.51).
  data.Vd[0] << Vector3d::Zero(), -model.gravity();
  for (int i = 0; i < n; ++i) {
    const Transform& T = data.T_local[body(i)];
    data.T_body[body(i)] = data.T_body[body(i) - 1] * T;
    visit_axis(model, i, [&](auto axis) {
      data.V[body(i)] = adjoint_inverse_times(T, data.V[body(i) - 1]) + axis.times(qd(i));
      data.Vd[body(i)] = adjoint_inverse_times(T, data.Vd[body(i) - 1]) + axis.ad_times(data.V[body(i)], qd(i));
    });
  }
  data.T_sb = data.T_body[body(n - 1)] * model.T_last_tip();
  composite_inertias(model, data);
  // Backward: the wrench F that moves bodies i…n at q̈ = 0 (c + g) and their momentum H (p and Cᵀq̇,
  // as momentum_terms). Gravity alone is a uniform acceleration of the whole subtree, so the wrench
  // that holds bodies i…n against it is their composite inertia times it, C_i (0, −R_0iᵀ g).
  Vector6d F = Vector6d::Zero(), H = Vector6d::Zero();
  for (int i = n - 1; i >= 0; --i) {
    const Vector6d& V = data.V[body(i)];
    Vector6d GV, GVd;
    inertia_times_both(model.body_inertia(i), V, data.Vd[body(i)], GV, GVd);
    F += GVd - ad_transpose_times(V, GV);
    H += GV;
    data.bias(i) = axis_dot(model, i, F);
    data.p(i) = axis_dot(model, i, H) + model.armature()[i] * qd(i);  // (M + diag(armature)) q̇
    data.ct_qd(i) = axis_dot(model, i, ad_transpose_times(V, H));
    Vector6d a_gravity;
    a_gravity << Vector3d::Zero(), -(data.T_body[body(i)].linear().transpose() * model.gravity());
    data.g(i) = axis_dot(model, i, data.composite[body(i)] * a_gravity);
    F = wrench_to_parent(data.T_local[body(i)], F);
    H = wrench_to_parent(data.T_local[body(i)], H);
  }
  data.c = data.bias - data.g;
  mass_matrix_from_composites(model, data);
  body_jacobian_from_poses(model, data);
  return data;
}

CHASLES_FLATTEN const Eigen::MatrixXd& mass_matrix(const RobotModel& model, Data& data, const JointVector& q) {
  local_transforms(model, data, q);
  composite_inertias(model, data);
  mass_matrix_from_composites(model, data);
  return data.M;
}

const Eigen::VectorXd& forward_dynamics(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd, const JointVector& tau, const Vector6d& F_tip) {
  check_joint_vector(model, qd, "qd");
  check_joint_vector(model, tau, "tau");
  mass_matrix(model, data, q);  // also sets data.T_local
  rnea<true, false>(model, data, qd.data(), nullptr, model.gravity(), F_tip, data.qdd);
  data.qdd = tau - data.qdd;
  data.M_llt.factorize(data.M);
  // A pivot (L_kk²) at rounding level is a singular M too: q̈ would be noise. The same test as
  // mass_matrix_defect's, so the two always agree.
  if (data.M_llt.info() != Eigen::Success ||
      !(data.M_llt.matrixLLT().diagonal().minCoeff() > std::sqrt(singular_pivot(data.M)))) {
    const std::string defect = mass_matrix_defect(model, data, q);
    throw DynamicsError(defect.empty() ? "the mass matrix is not positive definite" : defect);
  }
  cholesky_solve_in_place(data.M_llt.matrixLLT(), data.qdd);
  return data.qdd;
}

std::string mass_matrix_defect(const RobotModel& model, Data& data, const JointVector& q) {
  mass_matrix(model, data, q);
  // Cholesky by hand, outside any tick: the first pivot that vanishes names the joint whose
  // column adds nothing to those before it. Eigen's LLT only says that one did.
  const int n = model.dof();
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);
  const double scale = data.M.diagonal().cwiseAbs().maxCoeff();
  const double threshold = singular_pivot(data.M);
  for (int k = 0; k < n; ++k) {
    const double pivot = data.M(k, k) - L.row(k).head(k).squaredNorm();
    if (!(pivot > threshold)) {
      return "the mass matrix is singular: joint '" + model.joint(k).name +
             "' moves no inertia beyond what the joints before it move (Cholesky pivot " + std::to_string(pivot) +
             " against a largest diagonal of " + std::to_string(scale) +
             "), so forward dynamics cannot run; the bodies from it to the tip are massless or carry their mass on "
             "its axis: give them an inertia or end the chain before it";
    }
    L(k, k) = std::sqrt(pivot);
    for (int i = k + 1; i < n; ++i) L(i, k) = (data.M(i, k) - L.row(i).head(k).dot(L.row(k).head(k))) / L(k, k);
  }
  return {};
}

std::string mass_matrix_defect(const RobotModel& model) {
  Data data(model);
  Eigen::VectorXd q(model.dof());
  for (int i = 0; i < model.dof(); ++i) q(i) = 0.5 * (model.joint(i).limits.lower + model.joint(i).limits.upper);
  return mass_matrix_defect(model, data, q);
}

CHASLES_FLATTEN double kinetic_energy(const RobotModel& model, Data& data, const JointVector& q,
                                      const JointVector& qd) {
  check_joint_vector(model, qd, "qd");
  local_transforms(model, data, q);
  double energy = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    Vector6d& V = data.V[body(i)];
    V = adjoint_inverse_times(data.T_local[body(i)], data.V[body(i) - 1]) +
        visit_axis(model, i, [&](auto axis) { return axis.times(qd(i)); });
    energy += 0.5 * (V.dot(model.body_inertia(i) * V) + model.armature()[i] * qd(i) * qd(i));
  }
  return energy;
}

double potential_energy(const RobotModel& model, Data& data, const JointVector& q) {
  forward_kinematics(model, data, q);
  double energy = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    // m_i c_i in the base frame: m_i p_0i + R_0i h_i.
    const Transform& T = data.T_body[body(i)];
    const SpatialInertia& G = model.body_inertia(i);
    energy -= model.gravity().dot(G.mass * T.translation() + T.linear() * G.h);
  }
  return energy;
}

}  // namespace chasles
