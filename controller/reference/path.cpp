#include "controller/reference/path.hpp"

namespace chasles::controller {

PathMotion::PathMotion(int dof) : sampler_(dof), request_(dof) {}

void PathMotion::request(const Eigen::VectorXd& q_start, const Transform& T_goal, double duration) {
  request_.id = ++next_id_;
  request_.q_start = q_start;
  request_.T_goal = T_goal;
  request_.duration = duration;
  ready_ = true;
  pending_ = request_.id;
}

bool PathMotion::take_request(CartesianRequest& out) {
  if (!ready_) return false;
  out = request_;
  ready_ = false;
  return true;
}

bool PathMotion::answers(const JointPath& path) {
  if (path.request_id != pending_) return false;
  pending_ = -1;
  ik_iterations_ = path.ik_iterations;
  ik_residual_ = path.ik_residual;
  ik_converged_ = path.ok;
  return true;
}

void PathMotion::start(const JointPath& path, int64_t now_ns) {
  sampler_.start(path);
  start_ns_ = now_ns;
}

ReferenceSource::Progress PathMotion::advance(const Tick& tick, motion::Reference& ref) {
  return sample_at(sampler_, start_ns_, tick.now_ns, ref);  // the goal at rest once past the end
}

}  // namespace chasles::controller
