// Every reader of chasles messages on arbitrary bytes, and the controller behind them. Byte 0
// picks the reader, the rest is the message: 0 the controller's robot_state_t receiver, 1 its
// arm_target_t receiver and Controller::set_target, 2 the plant's joint_torque_command_t inbox,
// 3 the checked decoders of `chasles log` for all four types. What a receiver accepts must be
// what the contract promises (the arm's joint count, finite values), and after every input the
// controller ticks (1 ms later, with the latest state accepted) and must command finite torques
// within the effort limits, whatever it was fed. LCM is the in-process memq provider: no sockets.
#include <lcm/lcm-cpp.hpp>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "chasles/controller/controller.hpp"
#include "chasles/controller/lcm_io.hpp"
#include "chasles/core/model/urdf.hpp"
#include "chasles/tools/chasles/messages.hpp"
#include "chasles/tools/plant/messaging.hpp"
#include "fuzz/check.hpp"

namespace {

using namespace chasles;
using namespace chasles::controller;

struct Readers {
  RobotModel model = load_urdf_file(CHASLES_TEST_DATA "/panda.urdf", {"panda_hand"});
  int n = model.dof();
  lcm::LCM lcm{"memq://"};
  Rejections rejections;
  Mailbox<JointState> states{JointState(n)};
  SpscRing<Target> targets{4, Target(n)};
  StateReceiver state_receiver{lcm.getUnderlyingLCM(), "STATE", n, states, rejections};
  TargetReceiver target_receiver{lcm.getUnderlyingLCM(), "TARGET", n, targets, rejections};
  plant::CommandInbox commands{lcm, "COMMAND", n};
  Controller controller{model, Config::critically_damped(n, 20.0)};
  JointState state{n};  // the latest state accepted
  bool have_state = false;
  int64_t now_ns = 0;
};

template <typename Message>
void decode_as(const uint8_t* data, size_t size) {
  Message message;
  if (cli::decode_checked(data, size, message).empty()) FUZZ_CHECK(message.num_joints >= 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Readers* readers = new Readers();  // lives for the process, as in the daemon
  if (size == 0) return 0;
  Readers& r = *readers;
  const uint8_t* message = data + 1;
  const int bytes = static_cast<int>(size - 1);
  switch (data[0] % 4) {
    case 0:
      if (r.state_receiver.receive(message, bytes, r.now_ns).empty()) {
        JointState state(r.n);
        FUZZ_CHECK(r.states.read(state));
        FUZZ_CHECK(state.q.size() == r.n && state.q.allFinite() && state.qd.allFinite());
        r.state = state;
        r.have_state = true;
      }
      break;
    case 1:
      if (r.target_receiver.receive(message, bytes).empty()) {
        Target target(r.n);
        FUZZ_CHECK(r.targets.pop(target));
        FUZZ_CHECK(target.num_joints >= 0 && target.num_joints <= r.n);
        r.controller.set_target(target, r.now_ns);  // judges the meaning: limits, duration, finiteness
      }
      break;
    case 2: {
      const int64_t rejected = r.commands.rejected();
      r.commands.receive(message, bytes);
      if (r.commands.rejected() == rejected) {
        const joint_torque_command_t& command = r.commands.take();
        FUZZ_CHECK(command.num_joints == r.n && static_cast<int>(command.torque.size()) == r.n);
        for (double tau : command.torque) FUZZ_CHECK(std::isfinite(tau));
      }
      break;
    }
    default: {
      decode_as<robot_state_t>(message, size - 1);
      decode_as<joint_torque_command_t>(message, size - 1);
      decode_as<arm_target_t>(message, size - 1);
      decode_as<controller_status_t>(message, size - 1);
      cli::Cells cells;
      cli::message_cells(cli::message_type(message, size - 1), message, size - 1, {}, cells);
      FUZZ_CHECK(cells.names.size() == cells.values.size());
    }
  }
  r.now_ns += 1'000'000;
  if (r.controller.tick(r.now_ns, r.have_state ? &r.state : nullptr)) {
    const Eigen::VectorXd& tau = r.controller.torque();
    FUZZ_CHECK(tau.size() == r.n && tau.allFinite());
    for (int i = 0; i < r.n; ++i) FUZZ_CHECK(std::abs(tau[i]) <= r.model.joint(i).limits.effort);
  }
  return 0;
}
