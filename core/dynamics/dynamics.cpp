#include "core/dynamics/dynamics.hpp"

#include <cassert>
#include <cmath>
#include <limits>

#include "core/lie/se3.hpp"
#include "core/lie/sincos.hpp"
#include "core/model/joint_axis.hpp"

namespace chasles {
namespace {

size_t body(int joint_index) { return static_cast<size_t>(joint_index) + 1; }

// Aᵀ F for the wrench (m, f), of doubles or of lane pairs, with the axis as visit_axis gives it.
template <int K, class T>
CHASLES_ALWAYS_INLINE T axis_dot(AlignedRevoluteAxis<K> a, const T* m, const T*) {
  return a.sign * m[K];
}
template <class T>
CHASLES_ALWAYS_INLINE T axis_dot(const GeneralAxis& a, const T* m, const T* f) {
  const Vector6d& A = a.A;
  return A(0) * m[0] + A(1) * m[1] + A(2) * m[2] + A(3) * f[0] + A(4) * f[1] + A(5) * f[2];
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

// One step of the recursive algorithms between body i's frame and its parent's: x ↦ R x (+ p) with
// T_{i−1,i} = (R_M R_J(q_i), p). For an axis-aligned joint under a placement that is the identity
// or one rpy angle (RobotModel::placement_rotation) R is two turns in coordinate planes, applied as
// such: a turn of a 3-vector is 4 multiplications where R x is 9, and of a symmetric matrix 10
// where R I Rᵀ is 54 (M 20–27 % faster on the Panda and the UR5); a quarter turn is a swap. Any
// other joint takes its T_local in full.
struct Turn {
  int kind;  // 0, 1, 2: about e_kind by (c, s); 3: none; 4: the matrix *R; 5, 6, 7: a quarter about e_{kind−5} by s
  double c = 1.0, s = 0.0;
  const Matrix3d* R = nullptr;
};
static_assert(static_cast<int>(PlacementKind::RotationX) == 0 && static_cast<int>(PlacementKind::RotationZ) == 2 &&
                  static_cast<int>(PlacementKind::Identity) == 3 && static_cast<int>(PlacementKind::General) == 4 &&
                  static_cast<int>(PlacementKind::QuarterX) == 5 && static_cast<int>(PlacementKind::QuarterZ) == 7,
              "Turn's kinds are PlacementKind's");

// The step with joint i's axis as visit_axis gives it, so that a pass dispatches on each joint once
// per step, for the joint's turn and its share of a twist or a wrench alike, as Pinocchio visits
// its joint variant once per joint (RNEA 7 % and M 3 % fewer instructions than a separate
// dispatch for each).
template <class Axis>
struct ParentStep {
  Axis axis;
  double c, s;              // an aligned axis: R_J = R_K(c, s), c = cos q_i, s = σ sin q_i
  const Matrix3d* R_joint;  // a general axis: T_local's whole rotation (the placement's included)
  Turn placement;
  const Vector3d* p;
};

// Calls f(step) with step i (needs data.sin_q and data.cos_q, and data.T_local for a joint whose
// axis is not aligned).
template <class F>
CHASLES_ALWAYS_INLINE void visit_step(const RobotModel& model, const Data& data, int i, F&& f) {
  visit_axis(model, i, [&](auto axis) {
    using Axis = decltype(axis);
    if constexpr (is_general_axis<Axis>) {
      const Transform& T = data.T_local[body(i)];
      f(ParentStep<Axis>{axis, 1.0, 0.0, &T.linear(), {3}, &T.translation()});
    } else {
      const Transform& M = model.joint(i).T_parent_joint;
      const PlacementRotation& placement = model.placement_rotation(i);
      f(ParentStep<Axis>{axis,
                         data.cos_q(i),
                         axis.sign * data.sin_q(i),
                         nullptr,
                         {static_cast<int>(placement.kind), placement.c, placement.s, &M.linear()},
                         &M.translation()});
    }
  });
}

// v ← R_K(c, s) v: the turn by (c, s) in the plane of e_I, e_J.
template <int K, class T>
CHASLES_ALWAYS_INLINE void turn(double c, double s, T* v) {
  constexpr int I = (K + 1) % 3, J = (K + 2) % 3;
  const T a = v[I], b = v[J];
  v[I] = c * a - s * b;
  v[J] = s * a + c * b;
}

// v ← R_K(0, s) v, s = ±1: the quarter turn, a swap and a sign (a turn's products by c = 0 left out).
template <int K, class T>
CHASLES_ALWAYS_INLINE void quarter(double s, T* v) {
  constexpr int I = (K + 1) % 3, J = (K + 2) % 3;
  const T a = v[I], b = v[J];
  v[I] = -s * b;
  v[J] = s * a;
}

// v ← R v, or Rᵀ v when kInverse, for the 3×3 matrix R.
template <bool kInverse, class T>
CHASLES_ALWAYS_INLINE void apply_matrix(const Matrix3d& R, T* v) {
  const T a = v[0], b = v[1], c = v[2];
  for (int k = 0; k < 3; ++k) {
    v[k] = kInverse ? R(0, k) * a + R(1, k) * b + R(2, k) * c : R(k, 0) * a + R(k, 1) * b + R(k, 2) * c;
  }
}

// v ← R v, or Rᵀ v when kInverse, for the 3-vector v of doubles or of lane pairs.
template <bool kInverse = false, class T>
CHASLES_ALWAYS_INLINE void apply(const Turn& t, T* v) {
  const double s = kInverse ? -t.s : t.s;
  switch (t.kind) {
    case 0: return turn<0>(t.c, s, v);
    case 1: return turn<1>(t.c, s, v);
    case 2: return turn<2>(t.c, s, v);
    case 3: return;
    case 5: return quarter<0>(s, v);
    case 6: return quarter<1>(s, v);
    case 7: return quarter<2>(s, v);
    default: return apply_matrix<kInverse>(*t.R, v);
  }
}

// The joint's part of the same.
template <bool kInverse = false, class Axis, class T>
CHASLES_ALWAYS_INLINE void apply_joint(const ParentStep<Axis>& step, T* v) {
  if constexpr (is_general_axis<Axis>) {
    apply_matrix<kInverse>(*step.R_joint, v);
  } else {
    turn<Axis::kIndex>(step.c, kInverse ? -step.s : step.s, v);
  }
}

// Ad_{T⁻¹} V = (Rᵀ ω, Rᵀ (v − p × ω)) for T = T_{i−1,i}: a twist of body i−1's frame in body i's.
// Both halves turn side by side, entry k of each in one SSE2 register.
template <class Axis>
CHASLES_ALWAYS_INLINE Vector6d twist_to_child(const ParentStep<Axis>& step, const Vector6d& V) {
  using detail::Double2;
  const Vector3d& p = *step.p;
  Double2 x[3] = {{V(0), V(3) - (p(1) * V(2) - p(2) * V(1))},
                  {V(1), V(4) - (p(2) * V(0) - p(0) * V(2))},
                  {V(2), V(5) - (p(0) * V(1) - p(1) * V(0))}};
  apply<true>(step.placement, x);
  apply_joint<true>(step, x);
  Vector6d out;
  out << x[0][0], x[1][0], x[2][0], x[0][1], x[1][1], x[2][1];
  return out;
}

// [Ad_{T⁻¹}]ᵀ F = (R m + p × R f, R f): a wrench of body i's frame in body i−1's.
template <class Axis, class T>
CHASLES_ALWAYS_INLINE void wrench_to_parent(const ParentStep<Axis>& step, T* m, T* f) {
  apply_joint(step, f);
  apply_joint(step, m);
  apply(step.placement, f);
  apply(step.placement, m);
  const Vector3d& p = *step.p;
  m[0] += p(1) * f[2] - p(2) * f[1];
  m[1] += p(2) * f[0] - p(0) * f[2];
  m[2] += p(0) * f[1] - p(1) * f[0];
}

// The same with both halves side by side, for the RNEA's backward pass.
template <class Axis>
CHASLES_ALWAYS_INLINE Vector6d wrench_to_parent(const ParentStep<Axis>& step, const Vector6d& F) {
  using detail::Double2;
  Double2 x[3] = {{F(0), F(3)}, {F(1), F(4)}, {F(2), F(5)}};
  apply_joint(step, x);
  apply(step.placement, x);
  const Vector3d& p = *step.p;
  Vector6d out;
  out << x[0][0] + (p(1) * x[2][1] - p(2) * x[1][1]), x[1][0] + (p(2) * x[0][1] - p(0) * x[2][1]),
      x[2][0] + (p(0) * x[1][1] - p(1) * x[0][1]), x[0][1], x[1][1], x[2][1];
  return out;
}

// RNEA (MR eq. 8.50–8.53) with the terms that are zero left out at compile time. Gravity enters
// as a base acceleration V̇_0 = (0, −g). Expects joint_terms to be current.
template <bool kVelocity, bool kAcceleration>
CHASLES_FLATTEN void rnea(const RobotModel& model, Data& data, const double* qd, const double* qdd,
                          const Vector3d& gravity, const Vector6d& F_tip, Eigen::VectorXd& tau) {
  const int n = model.dof();
  // The arrays' addresses once: Eigen's SSE2 stores may alias anything, std::vector's pointers too.
  Vector6d* const Vs = data.V.data();
  Vector6d* const Vds = data.Vd.data();
  Vds[0] << Vector3d::Zero(), -gravity;
  for (int i = 0; i < n; ++i) {
    visit_step(model, data, i, [&](const auto& step) {
      Vector6d& Vd = Vds[body(i)];
      Vd = twist_to_child(step, Vds[body(i) - 1]);
      if constexpr (kVelocity) {
        Vector6d& V = Vs[body(i)];
        V = twist_to_child(step, Vs[body(i) - 1]);
        step.axis.add_times(V, qd[i]);
        step.axis.add_ad_times(Vd, V, qd[i]);
      }
      if constexpr (kAcceleration) step.axis.add_times(Vd, qdd[i]);
    });
  }
  // A zero tip wrench (the common call) needs no transform.
  Vector6d F = Vector6d::Zero();
  if (!(F_tip.array() == 0.0).all()) F = adjoint_inverse_transpose_times(model.T_last_tip(), F_tip);
  Vector6d* const Fs = data.F.data();
  for (int i = n - 1; i >= 0; --i) {
    const SpatialInertia& G = model.body_inertia(i);
    if constexpr (kVelocity) {
      const Vector6d& V = Vs[body(i)];
      Vector6d GVd, GV;
      inertia_times_both(G, Vds[body(i)], V, GVd, GV);
      F += GVd - ad_transpose_times(V, GV);
    } else {
      F += G * Vds[body(i)];
    }
    Fs[body(i)] = F;
    tau(i) = visit_axis(model, i, [&](auto axis) { return axis.dot(F); });
    // The rotor's reflected inertia, on the joint alone (M's diagonal; see mass_matrix_from_columns).
    if constexpr (kAcceleration) tau(i) += model.armature()[i] * qdd[i];
    if (i == 0) break;  // the base's wrench is unused
    visit_step(model, data, i, [&](const auto& step) { F = wrench_to_parent(step, F); });
  }
}

// A composite inertia held in scalars, its rotational part symmetric: d the diagonal, o[k] the
// entry off the diagonal that involves neither index k (o[0] = I_yz, o[1] = I_zx, o[2] = I_xy).
// Scalars because each CRBA step writes it entry by entry, and the next step must read those
// entries back from registers, not through 2-wide loads from the stores just made, which the CPU
// cannot forward: written to data.composite and read back, the same steps made M 35–40 % slower.
struct CompositeInertia {
  double mass, h[3], d[3], o[3];

  explicit CompositeInertia(const SpatialInertia& G)
      : mass(G.mass), h{G.h(0), G.h(1), G.h(2)}, d{G.I(0, 0), G.I(1, 1), G.I(2, 2)}, o{G.I(1, 2), G.I(2, 0), G.I(0, 1)} {}

  void add(const SpatialInertia& G) {
    mass += G.mass;
    for (int k = 0; k < 3; ++k) {
      h[k] += G.h(k);
      d[k] += G.I(k, k);
    }
    o[0] += G.I(1, 2);
    o[1] += G.I(2, 0);
    o[2] += G.I(0, 1);
  }

  Matrix3d I() const {
    Matrix3d out;
    out << d[0], o[2], o[1], o[2], d[1], o[0], o[1], o[0], d[2];
    return out;
  }

  // I ← R_K I R_Kᵀ, h ← R_K h: the 2×2 block in the plane of e_I, e_J by c², s² and cs (the products
  // apart, then summed: a shorter chain than the double angle's), the entries with K as a vector.
  template <int K>
  CHASLES_ALWAYS_INLINE void turn_about(double c, double s) {
    constexpr int I = (K + 1) % 3, J = (K + 2) % 3;
    turn<K>(c, s, h);
    const double cc = c * c, ss = s * s, cs = c * s, a = d[I], b = d[J], e = o[K];
    d[I] = (cc * a + ss * b) - 2.0 * cs * e;
    d[J] = (ss * a + cc * b) + 2.0 * cs * e;
    o[K] = cs * (a - b) + (cc - ss) * e;
    const double IK = o[J], JK = o[I];
    o[J] = c * IK - s * JK;
    o[I] = s * IK + c * JK;
  }

  // The same for a quarter turn (c = 0, s = ±1): the two diagonal entries swap, their product of
  // inertia changes sign, and the other two swap with a sign.
  template <int K>
  CHASLES_ALWAYS_INLINE void quarter_about(double s) {
    constexpr int I = (K + 1) % 3, J = (K + 2) % 3;
    quarter<K>(s, h);
    const double a = d[I];
    d[I] = d[J];
    d[J] = a;
    o[K] = -o[K];
    const double IK = o[J], JK = o[I];
    o[J] = -s * JK;
    o[I] = s * IK;
  }

  // I ← R I Rᵀ, h ← R h for any rotation R.
  CHASLES_ALWAYS_INLINE void rotate_by(const Matrix3d& R) {
    const Matrix3d RI = R * I();
    const Matrix3d rotated = RI * R.transpose();
    const Vector3d Rh = R * Eigen::Map<const Vector3d>(h);
    for (int k = 0; k < 3; ++k) h[k] = Rh(k);
    for (int k = 0; k < 3; ++k) d[k] = rotated(k, k);
    o[0] = rotated(1, 2);
    o[1] = rotated(2, 0);
    o[2] = rotated(0, 1);
  }

  CHASLES_ALWAYS_INLINE void rotate(const Turn& t) {
    switch (t.kind) {
      case 0: return turn_about<0>(t.c, t.s);
      case 1: return turn_about<1>(t.c, t.s);
      case 2: return turn_about<2>(t.c, t.s);
      case 3: return;
      case 5: return quarter_about<0>(t.s);
      case 6: return quarter_about<1>(t.s);
      case 7: return quarter_about<2>(t.s);
      default: return rotate_by(*t.R);
    }
  }

  // The same inertia about a point −p from the frame's origin (Featherstone's inertia transform,
  // the rotation done): h' = h + m p, I' = I − p h'ᵀ − h pᵀ + p·(h + h') 1, as [a][b] = b aᵀ − (a·b) 1.
  CHASLES_ALWAYS_INLINE void shift(const Vector3d& p) {
    double moved[3];
    for (int k = 0; k < 3; ++k) moved[k] = h[k] + mass * p(k);
    const double trace = p(0) * (h[0] + moved[0]) + p(1) * (h[1] + moved[1]) + p(2) * (h[2] + moved[2]);
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      d[k] += trace - p(k) * moved[k] - h[k] * p(k);
      o[k] -= p(a) * moved[b] + h[a] * p(b);
    }
    for (int k = 0; k < 3; ++k) h[k] = moved[k];
  }

  // Carried into the parent's frame.
  template <class Axis>
  CHASLES_ALWAYS_INLINE void to_parent(const ParentStep<Axis>& step) {
    if constexpr (is_general_axis<Axis>) {
      rotate_by(*step.R_joint);
    } else {
      turn_about<Axis::kIndex>(step.c, step.s);
    }
    rotate(step.placement);
    shift(*step.p);
  }

  // C A for A = ±e_K (revolute): (I e_K, e_K × h) times the sign, from the registers.
  template <int K>
  CHASLES_ALWAYS_INLINE Vector6d times_axis(AlignedRevoluteAxis<K> a) const {
    constexpr int I = AlignedRevoluteAxis<K>::I, J = AlignedRevoluteAxis<K>::J;
    double column[3];
    column[K] = d[K];
    column[I] = o[J];
    column[J] = o[I];
    Vector6d P;
    P << a.sign * column[0], a.sign * column[1], a.sign * column[2], 0.0, 0.0, 0.0;
    P(3 + I) = -a.sign * h[J];
    P(3 + J) = a.sign * h[I];
    return P;
  }

  // C A for any A = (ω, v): (I ω + h × v, m v − h × ω) (MR eq. 8.32's spatial inertia).
  CHASLES_ALWAYS_INLINE Vector6d times_axis(GeneralAxis a) const {
    const Vector3d hv = Eigen::Map<const Vector3d>(h);
    const Vector3d w = a.A.head<3>(), v = a.A.tail<3>();
    Vector6d P;
    P << I() * w + hv.cross(v), mass * v - hv.cross(w);
    return P;
  }
};

// data.crb_column[i] = C_i A_i for every joint, the composite inertias C_i of bodies i…n built
// tip to base (MR §8.4, Featherstone's CRBA): C_i = G_i + C_{i+1} carried into frame i.
CHASLES_FLATTEN void crb_columns(const RobotModel& model, Data& data) {
  const int n = model.dof();
  CompositeInertia C(model.body_inertia(n - 1));
  for (int i = n - 1;; --i) {
    visit_step(model, data, i, [&](const auto& step) {
      data.crb_column[body(i)] = C.times_axis(step.axis);
      if (i > 0) C.to_parent(step);
    });
    if (i == 0) break;
    C.add(model.body_inertia(i - 1));
  }
}

// M from data.crb_column: column i is the wrench C_i A_i that accelerates joint i alone, carried
// toward the base. Columns go two at a time, one in each lane of an SSE2 register, through the
// steps they share: every operation is then the same in both lanes, and half as many. The one place
// M is assembled, so the armature is added here (to the diagonal: a rotor turns with its own joint
// only) and no caller can leave it out.
CHASLES_FLATTEN void mass_matrix_from_columns(const RobotModel& model, Data& data) {
  using detail::Double2;
  const int n = model.dof();
  for (int i = 0; i < n; ++i) {
    data.M(i, i) = visit_axis(model, i, [&](auto axis) { return axis.dot(data.crb_column[body(i)]); }) +
                   model.armature()[i];
  }
  for (int a = n % 2; a < n; a += 2) {  // the pair (a, a + 1), and column 0 alone when n is odd
    const Vector6d& A = data.crb_column[body(a)];
    const Vector6d& B = data.crb_column[body(a + 1)];
    // Column a + 1 first takes the step into frame a alone.
    double mb[3] = {B(0), B(1), B(2)}, fb[3] = {B(3), B(4), B(5)};
    visit_step(model, data, a + 1, [&](const auto& step) { wrench_to_parent(step, mb, fb); });
    Double2 m[3], f[3];
    for (int k = 0; k < 3; ++k) {
      m[k] = Double2{A(k), mb[k]};
      f[k] = Double2{A(3 + k), fb[k]};
    }
    data.M(a, a + 1) = data.M(a + 1, a) = visit_axis(model, a, [&](auto axis) { return axis_dot(axis, mb, fb); });
    // The step and the next joint's share in visits of their own: in one visit per joint, the
    // pair no longer stayed in registers (M 10–14 % more instructions).
    for (int j = a; j > 0; --j) {
      visit_step(model, data, j, [&](const auto& step) { wrench_to_parent(step, m, f); });
      const Double2 entries = visit_axis(model, j - 1, [&](auto axis) { return axis_dot(axis, m, f); });
      data.M(j - 1, a) = data.M(a, j - 1) = entries[0];
      data.M(j - 1, a + 1) = data.M(a + 1, j - 1) = entries[1];
    }
  }
}

bool every_axis_aligned(const RobotModel& model) {
  for (int i = 0; i < model.dof(); ++i) {
    if (model.joint_axis(i).kind == AxisKind::General) return false;
  }
  return true;
}

// What visit_step reads: sin q_i and cos q_i, and, where a joint's axis is not aligned, T_local
// (for all joints then, in the one pass). The steps turn by the angles, so no transform is formed.
void joint_terms(const RobotModel& model, Data& data, const JointVector& q) {
  if (!every_axis_aligned(model)) return local_transforms(model, data, q);
  check_joint_vector(model, q, "q");
  assert(model.check(data) && "a Data sized for another model");
  ++data.passes.joint_transforms;
  sin_cos(q.data(), model.dof(), data.sin_q.data(), data.cos_q.data());
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
  joint_terms(model, data, q);
  rnea<true, true>(model, data, qd.data(), qdd.data(), model.gravity(), F_tip, data.tau);
  return data.tau;
}

const Eigen::VectorXd& gravity_torques(const RobotModel& model, Data& data, const JointVector& q) {
  joint_terms(model, data, q);
  rnea<false, false>(model, data, nullptr, nullptr, model.gravity(), Vector6d::Zero(), data.g);
  return data.g;
}

const Eigen::VectorXd& velocity_product(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd) {
  check_joint_vector(model, qd, "qd");
  joint_terms(model, data, q);
  rnea<true, false>(model, data, qd.data(), nullptr, Vector3d::Zero(), Vector6d::Zero(), data.c);
  return data.c;
}

CHASLES_FLATTEN const Eigen::VectorXd& momentum_terms(const RobotModel& model, Data& data, const JointVector& q,
                                                      const JointVector& qd) {
  check_joint_vector(model, qd, "qd");
  joint_terms(model, data, q);
  const int n = model.dof();
  // Forward: body twists V_i and the gravity each body feels, as the base acceleration (0, −g)
  // seen from body i (the V̇_i of a chain at rest).
  Vector6d* const Vs = data.V.data();  // the addresses once, as in rnea
  Vector6d* const Vds = data.Vd.data();
  Vds[0] << Vector3d::Zero(), -model.gravity();
  for (int i = 0; i < n; ++i) {
    visit_step(model, data, i, [&](const auto& step) {
      Vs[body(i)] = twist_to_child(step, Vs[body(i) - 1]);
      step.axis.add_times(Vs[body(i)], qd(i));
      Vds[body(i)] = twist_to_child(step, Vds[body(i) - 1]);
    });
  }
  // Backward: subtree momentum H and gravity wrench W, carried toward the base as wrenches are.
  Vector6d H = Vector6d::Zero(), W = Vector6d::Zero();
  for (int i = n - 1; i >= 0; --i) {
    const Vector6d& V = Vs[body(i)];
    Vector6d GV, GVd;
    inertia_times_both(model.body_inertia(i), V, Vds[body(i)], GV, GVd);
    H += GV;
    W += GVd;
    visit_step(model, data, i, [&](const auto& step) {
      data.p(i) = step.axis.dot(H) + model.armature()[i] * qd(i);  // (M + diag(armature)) q̇
      data.ct_qd(i) = step.axis.dot(ad_transpose_times(V, H));
      data.g(i) = step.axis.dot(W);
      if (i == 0) return;  // the base's wrenches are unused
      H = wrench_to_parent(step, H);
      W = wrench_to_parent(step, W);
    });
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
  Vector6d* const Vs = data.V.data();  // the addresses once, as in rnea
  Vector6d* const Vds = data.Vd.data();
  Vds[0] << Vector3d::Zero(), -model.gravity();
  for (int i = 0; i < n; ++i) {
    data.T_body[body(i)] = data.T_body[body(i) - 1] * data.T_local[body(i)];
    visit_step(model, data, i, [&](const auto& step) {
      Vector6d& V = Vs[body(i)];
      V = twist_to_child(step, Vs[body(i) - 1]);
      step.axis.add_times(V, qd(i));
      Vector6d& Vd = Vds[body(i)];
      Vd = twist_to_child(step, Vds[body(i) - 1]);
      step.axis.add_ad_times(Vd, V, qd(i));
    });
  }
  data.T_sb = data.T_body[body(n - 1)] * model.T_last_tip();
  crb_columns(model, data);
  // Backward: the wrench F that moves bodies i…n at q̈ = 0 (c + g) and their momentum H (p and Cᵀq̇,
  // as momentum_terms). Gravity alone is a uniform acceleration of the whole subtree, so the wrench
  // that holds bodies i…n against it is their composite inertia times it, C_i (0, a) with
  // a = −R_0iᵀ g, whose share for joint i is A_iᵀ C_i (0, a) = (C_i A_i)ᵀ (0, a), C_i being symmetric.
  Vector6d F = Vector6d::Zero(), H = Vector6d::Zero();
  for (int i = n - 1; i >= 0; --i) {
    const Vector6d& V = Vs[body(i)];
    Vector6d GV, GVd;
    inertia_times_both(model.body_inertia(i), V, Vds[body(i)], GV, GVd);
    F += GVd - ad_transpose_times(V, GV);
    H += GV;
    const Vector3d a_gravity = -(data.T_body[body(i)].linear().transpose() * model.gravity());
    data.g(i) = data.crb_column[body(i)].tail<3>().dot(a_gravity);
    visit_step(model, data, i, [&](const auto& step) {
      data.bias(i) = step.axis.dot(F);
      data.p(i) = step.axis.dot(H) + model.armature()[i] * qd(i);  // (M + diag(armature)) q̇
      data.ct_qd(i) = step.axis.dot(ad_transpose_times(V, H));
      if (i == 0) return;  // the base's wrenches are unused
      F = wrench_to_parent(step, F);
      H = wrench_to_parent(step, H);
    });
  }
  data.c = data.bias - data.g;
  mass_matrix_from_columns(model, data);
  body_jacobian_from_poses(model, data);
  return data;
}

CHASLES_FLATTEN const Eigen::MatrixXd& mass_matrix(const RobotModel& model, Data& data, const JointVector& q) {
  joint_terms(model, data, q);
  crb_columns(model, data);
  mass_matrix_from_columns(model, data);
  return data.M;
}

const Eigen::VectorXd& forward_dynamics(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd, const JointVector& tau, const Vector6d& F_tip) {
  check_joint_vector(model, qd, "qd");
  check_joint_vector(model, tau, "tau");
  joint_terms(model, data, q);
  crb_columns(model, data);
  mass_matrix_from_columns(model, data);
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
  joint_terms(model, data, q);
  double energy = 0.0;
  for (int i = 0; i < model.dof(); ++i) {
    Vector6d& V = data.V[body(i)];
    visit_step(model, data, i, [&](const auto& step) {
      V = twist_to_child(step, data.V[body(i) - 1]);
      step.axis.add_times(V, qd(i));
    });
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
