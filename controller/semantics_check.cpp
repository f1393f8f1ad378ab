#include "controller/semantics_check.hpp"

#include <cmath>

namespace chasles::controller {

namespace {
// A share this far from 0 is a driver's gravity (noise, friction and the command's change over a
// step leave a few per cent); between the two bounds, no verdict: the next window decides.
constexpr double kAgreedBelow = 0.25, kMismatchAbove = 0.5;
}  // namespace

TorqueSemanticsCheck::Verdict TorqueSemanticsCheck::update(const Eigen::Ref<const Eigen::VectorXd>& applied,
                                                           const Eigen::Ref<const Eigen::VectorXd>& commanded,
                                                           const Eigen::Ref<const Eigen::VectorXd>& g, double dt) {
  if (!(dt > 0.0)) return Verdict::kUndecided;
  along_ += dt * (applied - commanded).dot(g);
  squared_ += dt * g.squaredNorm();
  time_ += dt;
  if (time_ < kWindow) return Verdict::kUndecided;
  const bool enough = squared_ >= kMinGravity * kMinGravity * time_;
  const double share = enough ? along_ / squared_ : 0.0;
  restart();
  if (!enough) return Verdict::kUndecided;
  share_ = share;
  if (std::abs(share) < kAgreedBelow) return Verdict::kAgreed;
  if (share > kMismatchAbove) return Verdict::kDriverAddsGravity;
  if (share < -kMismatchAbove) return Verdict::kDriverAddsNothing;
  return Verdict::kUndecided;
}

}  // namespace chasles::controller
