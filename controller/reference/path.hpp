// A Cartesian goal's joint path (cartesian.hpp): the hand-over to the IK worker — the request the
// real-time thread makes, the plan it waits for — and the path's following once it comes back.
#pragma once

#include <cstdint>

#include "controller/cartesian.hpp"
#include "controller/reference/source.hpp"

namespace chasles::controller {

class PathMotion final : public ReferenceSource {
 public:
  explicit PathMotion(int dof);
  /// Asks the IK worker for the path from q_start (at rest) to T_goal over `duration`; a request
  /// awaited before is superseded.
  void request(const Eigen::VectorXd& q_start, const Transform& T_goal, double duration);
  /// The request made, once: true and `out` filled, else false.
  bool take_request(CartesianRequest& out);
  /// Drops the request awaited, if any: its path will not be followed.
  void drop() { pending_ = -1; }
  /// Whether `path` answers the request awaited; if so it is no longer awaited and its IK figures
  /// are kept, whether it succeeded or not.
  bool answers(const JointPath& path);
  /// Follows `path` from now_ns (copied: the caller's buffer may be reused at once).
  void start(const JointPath& path, int64_t now_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  void delay(int64_t ns) override { start_ns_ += ns; }

  /// The IK figures of the last plan: summed iterations, worst position error (m), whether every
  /// waypoint converged.
  int ik_iterations() const { return ik_iterations_; }
  double ik_residual() const { return ik_residual_; }
  bool ik_converged() const { return ik_converged_; }

 private:
  JointPathSampler sampler_;
  int64_t start_ns_ = 0;
  CartesianRequest request_;
  bool ready_ = false;
  int64_t pending_ = -1;  // id of the request whose path is awaited; −1: none
  int64_t next_id_ = 0;
  int ik_iterations_ = 0;
  double ik_residual_ = 0.0;
  bool ik_converged_ = false;
};

}  // namespace chasles::controller
