#include "controller/signals.hpp"

namespace chasles::controller {

const char* to_string(Mode mode) {
  switch (mode) {
    case Mode::kWaiting:
      return "WAITING";
    case Mode::kRunning:
      return "RUNNING";
    case Mode::kHolding:
      return "HOLDING";
    case Mode::kFault:
      return "FAULT";
    case Mode::kReflex:
      return "REFLEX";
  }
  return "?";
}

const char* to_string(TrajectoryProgress::Outcome outcome) {
  switch (outcome) {
    case TrajectoryProgress::kNone:
      return "NONE";
    case TrajectoryProgress::kActive:
      return "ACTIVE";
    case TrajectoryProgress::kSucceeded:
      return "SUCCEEDED";
    case TrajectoryProgress::kAborted:
      return "ABORTED";
    case TrajectoryProgress::kPreempted:
      return "PREEMPTED";
    case TrajectoryProgress::kRejected:
      return "REJECTED";
  }
  return "?";
}

const char* to_string(JogProgress::Limit limit) {
  switch (limit) {
    case JogProgress::kNone:
      return "none";
    case JogProgress::kVelocity:
      return "velocity limit";
    case JogProgress::kPosition:
      return "position limit";
    case JogProgress::kSingularity:
      return "singularity";
  }
  return "?";
}

}  // namespace chasles::controller
