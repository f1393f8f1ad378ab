// Every reader of chasles messages on arbitrary bytes, and the controller behind them. Byte 0
// picks the reader, the rest is the message: 0 the controller's robot_state_t receiver, 1 its
// arm_target_t receiver and Controller::set_target, 2 the plant's joint_torque_command_t inbox,
// 3 the checked decoders for any arm (`chasles log`'s four types, control_mode_t and payload_t),
// 4 the controller's watch for other senders on its command channel, 5 its control_mode_t receiver
// and Controller::set_law, 6 its payload_t receiver, the model built with the payload (as the
// daemon's worker does) and Controller::set_model, 7 the direct Bus's reading of a UDP datagram as an
// LCM small message (parse_lcm_datagram) and, when it is one, the state receiver on its payload,
// or as a fragment of a large one (parse_lcm_fragment, FragmentAssembler); 8
// its joint_trajectory_t receiver and Controller::set_trajectory; 9 its joint_setpoint_t receiver
// and Controller::set_setpoint; 10 its jog_command_t receiver and Controller::set_jog; 11 its
// tip_setpoint_t receiver and Controller::set_tip_setpoint; 12 the checked decoders of Drake's iiwa
// and Panda messages, for the arm and for any arm, and the protocols' status readers, whose state the
// controller then ticks on and whose command the driver's checked decoder must take; 13 the scene
// message (scene_t's checked decoder and decode_scene, what it takes re-encoded and decoded again);
// 14–15 as 3. (Byte 0 modulo 16, so the seeds' ASCII selectors '0'…'9', ':', ';', '<' and '='
// pick 0…13.)
// What a reader accepts must be what the contract
// promises (the arm's joint count, finite values; for the watch, a command of its own, once; for a
// payload, a body the model can carry), and after every input the controller ticks (1 ms later,
// with the latest state accepted) and must command finite torques within the effort limits,
// whatever it was fed. The readers take bytes: no sockets.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "controller/controller.hpp"
#include "controller/transport/lcm_io.hpp"
#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "controller/transport/realtime/fragments.hpp"
#include "controller/transport/scene_message.hpp"
#include "core/geometry/scene_file.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "lcmtypes/checked.hpp"
#include "tools/cli/messages.hpp"
#include "tools/simulation/messaging.hpp"
#include "fuzz/check.hpp"

namespace {

using namespace chasles;
using namespace chasles::controller;

struct Readers {
  RobotModel model = load_urdf_file(CHASLES_TEST_DATA "/panda.urdf", {"panda_hand"});
  int n = model.dof();
  SimulatedClock clock;
  Mailbox<JointState> states{JointState(n)};
  SpscRing<Target> targets{4, Target(n)};
  FragmentAssembler fragments{1 << 20};  // across inputs, as the bus's assembler lives
  SpscRing<motion::Waypoints> trajectories{1, motion::Waypoints(n)};
  TrajectoryReceiver trajectory_receiver{model, trajectories};
  SpscRing<Setpoint> setpoints{1, Setpoint(n)};
  SetpointReceiver setpoint_receiver{n, setpoints};
  SpscRing<Jog> jogs{1, Jog(n)};
  JogReceiver jog_receiver{n, jogs};
  SpscRing<TipSetpoint> tip_setpoints{1, TipSetpoint{}};
  TipSetpointReceiver tip_setpoint_receiver{tip_setpoints};
  StateReceiver state_receiver{n, states};
  TargetReceiver target_receiver{n, targets};
  plant::CommandInbox commands{clock, "COMMAND", n};
  Controller controller{model, Config::critically_damped(n, 20.0)};
  SentCommands sent;
  CommandWatch watch{sent};
  CommandWriter publisher{Protocol::kChasles, n, TorqueSemantics::kFull};
  SpscRing<LawSettings> laws{4, LawSettings(n)};
  ModeReceiver mode_receiver{n, laws};
  Mailbox<Payload> payloads{Payload{}};
  Doorbell payload_bell;
  PayloadReceiver payload_receiver{payloads, payload_bell};
  std::unique_ptr<RobotModel> loaded;  // the model with the latest payload, which the controller holds
  int64_t sent_seq = 0;
  std::vector<bool> heard{false};  // by seq: our command has come back
  StatusReader iiwa_reader{Protocol::kDrakeIiwa, n};
  StatusReader panda_reader{Protocol::kDrakePanda, n};
  CommandWriter iiwa_writer{Protocol::kDrakeIiwa, n, TorqueSemantics::kOverlay, IiwaPositions::kMeasured};
  CommandWriter panda_writer{Protocol::kDrakePanda, n, TorqueSemantics::kOverlay};
  Data data{model};
  JointState state{n};  // the latest state accepted
  bool have_state = false;
  int64_t now_ns = 0;
};

int64_t big_endian(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = v << 8 | p[i];
  return static_cast<int64_t>(v);
}

// Two commands of ours per input, stamped utime = 1000·seq: the odd one comes back at once (ours)
// and again (a replay: foreign); the even one stays unheard, for the input to name. The input is
// ours exactly when it is a valid joint_torque_command_t (any arm's) and names an unheard command
// of ours, with its utime, still within the window the watch remembers.
void judge_the_command_watch(Readers& r, const uint8_t* message, int bytes) {
  for (int k = 0; k < 2; ++k) {
    const int64_t seq = ++r.sent_seq;
    JointState answered(r.n);
    answered.seq = 0;
    r.publisher.write(1000 * seq, seq, answered, Eigen::VectorXd::Zero(r.n), Eigen::VectorXd::Zero(r.n));
    r.sent.record(seq, 1000 * seq);
    r.heard.push_back(false);
    if (k == 0) {
      const auto& own = r.publisher.bytes();
      FUZZ_CHECK(!r.watch.receive(own.data(), own.size()));
      FUZZ_CHECK(r.watch.receive(own.data(), own.size()));
      r.heard[size_t(seq)] = true;
    }
  }
  const int64_t seq = bytes >= 32 ? big_endian(message + 16) : -1;
  joint_torque_command_t command;
  const bool names_unheard_own =
      bytes >= 32 && messages::decode_checked(message, size_t(bytes), command).empty() &&
      seq > std::max<int64_t>(0, r.sent_seq - SentCommands::kWindow) && seq <= r.sent_seq &&
      big_endian(message + 8) == 1000 * seq && !r.heard[size_t(seq)];
  const int64_t before = r.watch.foreign();
  const bool foreign = r.watch.receive(message, size_t(bytes));
  FUZZ_CHECK(foreign == !names_unheard_own);
  FUZZ_CHECK(r.watch.foreign() == before + (foreign ? 1 : 0));
  if (!foreign) r.heard[size_t(seq)] = true;
}

bool all_finite(const double* values, size_t n) {
  return std::all_of(values, values + n, [](double x) { return std::isfinite(x); });
}
bool all_finite(const std::vector<double>& values) { return all_finite(values.data(), values.size()); }

// A control_mode_t the checked decoder took: its arrays sized for its counts.
bool sized_for_its_counts(const control_mode_t& m) {
  return m.num_joints >= 0 && m.num_posture >= 0 && m.joint_stiffness.size() == size_t(m.num_joints) &&
         m.joint_damping.size() == size_t(m.num_joints) && m.nullspace_posture.size() == size_t(m.num_posture);
}

// A Drake message the checked decoder took: each array sized by its count. For the arm with finite
// numbers required: statuses of exactly the arm's joints, commands of 0 or the arm's in each count,
// every number finite (but an iiwa status's joint_position_ipo, which the driver sets NaN). For any
// arm: what was taken encodes back to the very bytes (no strings, no booleans to normalise).
bool sized_for_its_counts(const drake::lcmt_iiwa_status& m) {
  for (const auto* v : {&m.joint_position_measured, &m.joint_velocity_estimated, &m.joint_position_commanded,
                        &m.joint_position_ipo, &m.joint_torque_measured, &m.joint_torque_commanded,
                        &m.joint_torque_external}) {
    if (v->size() != size_t(m.num_joints)) return false;
  }
  return m.num_joints >= 0;
}
bool sized_for_its_counts(const drake::lcmt_panda_status& m) {
  for (const auto* v : {&m.joint_position, &m.joint_position_desired, &m.joint_velocity, &m.joint_velocity_desired,
                        &m.joint_acceleration_desired, &m.joint_torque, &m.joint_torque_desired,
                        &m.joint_torque_external}) {
    if (v->size() != size_t(m.num_joints)) return false;
  }
  return m.num_joints >= 0;
}
bool sized_for_its_counts(const drake::lcmt_iiwa_command& m) {
  return m.num_joints >= 0 && m.num_torques >= 0 && m.joint_position.size() == size_t(m.num_joints) &&
         m.joint_torque.size() == size_t(m.num_torques);
}
bool sized_for_its_counts(const drake::lcmt_panda_command& m) {
  return m.num_joint_position >= 0 && m.num_joint_velocity >= 0 && m.num_joint_torque >= 0 &&
         m.joint_position.size() == size_t(m.num_joint_position) &&
         m.joint_velocity.size() == size_t(m.num_joint_velocity) && m.joint_torque.size() == size_t(m.num_joint_torque);
}
bool fits(const drake::lcmt_iiwa_status& m, int n) {
  return m.num_joints == n && all_finite(m.joint_position_measured) && all_finite(m.joint_velocity_estimated) &&
         all_finite(m.joint_position_commanded) && all_finite(m.joint_torque_measured) &&
         all_finite(m.joint_torque_commanded) && all_finite(m.joint_torque_external);
}
bool fits(const drake::lcmt_panda_status& m, int n) {
  return m.num_joints == n && all_finite(m.joint_position) && all_finite(m.joint_position_desired) &&
         all_finite(m.joint_velocity) && all_finite(m.joint_velocity_desired) &&
         all_finite(m.joint_acceleration_desired) && all_finite(m.joint_torque) && all_finite(m.joint_torque_desired) &&
         all_finite(m.joint_torque_external) && std::isfinite(m.control_command_success_rate);
}
bool fits(const drake::lcmt_iiwa_command& m, int n) {
  return (m.num_joints == 0 || m.num_joints == n) && (m.num_torques == 0 || m.num_torques == n) &&
         all_finite(m.joint_position) && all_finite(m.joint_torque);
}
bool fits(const drake::lcmt_panda_command& m, int n) {
  return (m.num_joint_position == 0 || m.num_joint_position == n) &&
         (m.num_joint_velocity == 0 || m.num_joint_velocity == n) &&
         (m.num_joint_torque == 0 || m.num_joint_torque == n) && all_finite(m.joint_position) &&
         all_finite(m.joint_velocity) && all_finite(m.joint_torque);
}

template <typename Message>
void judge_drake(const uint8_t* data, size_t size, int n) {
  Message message;
  if (messages::decode_checked(data, size, message, n, messages::Finite::Required).empty()) {
    FUZZ_CHECK(sized_for_its_counts(message));
    FUZZ_CHECK(fits(message, n));
  }
  if (messages::decode_checked(data, size, message, messages::kAnyArm).empty()) {
    FUZZ_CHECK(sized_for_its_counts(message));
    FUZZ_CHECK(message.getEncodedSize() == static_cast<int>(size));
    std::vector<uint8_t> again(size);
    FUZZ_CHECK(message.encode(again.data(), 0, static_cast<int>(size)) == static_cast<int>(size));
    FUZZ_CHECK(std::equal(again.begin(), again.end(), data));
  }
}

// A Drake status a protocol's reader takes becomes the state the controller ticks on: sized for the
// arm, finite. The command written for it (the state's own effort as the torque, g(q) subtracted)
// is one the driver's side takes: the arm's counts, finite, the state's utime.
template <typename Command>
void judge_a_drake_status(Readers& r, StatusReader& reader, CommandWriter& writer, const uint8_t* message,
                          size_t size) {
  JointState state(r.n);
  if (!reader.read(message, size, r.now_ns, state).empty()) return;
  FUZZ_CHECK(state.q.size() == r.n && state.q.allFinite() && state.qd.allFinite() && state.effort.allFinite());
  FUZZ_CHECK(reader.tau_ext().size() == r.n && reader.tau_ext().allFinite());
  FUZZ_CHECK(state.seq >= 0);
  r.state = state;
  r.have_state = true;
  const Eigen::VectorXd& g = gravity_torques(r.model, r.data, state.q);
  writer.write(0, 0, state, state.effort, g);
  Command command;
  const auto& bytes = writer.bytes();
  const bool finite = state.effort.allFinite() && g.allFinite() && (state.effort - g).allFinite();
  const std::string why =
      messages::decode_checked(bytes.data(), bytes.size(), command, r.n, messages::Finite::Required);
  FUZZ_CHECK(why.empty() || (!finite && why.rfind("with non-finite", 0) == 0));
  FUZZ_CHECK(command.utime == state.utime);
}

template <typename Message>
void decode_as(const uint8_t* data, size_t size) {
  Message message;
  if (!cli::decode_checked(data, size, message).empty()) return;
  if constexpr (std::is_same_v<Message, control_mode_t>) {
    FUZZ_CHECK(sized_for_its_counts(message));
  } else if constexpr (!messages::detail::kCountless<Message>) {
    FUZZ_CHECK(message.num_joints >= 0);
  }
  if constexpr (std::is_same_v<Message, control_mode_t> || messages::detail::kCountless<Message>) {
    // No string or boolean to normalise: what was taken encodes back to the very bytes.
    FUZZ_CHECK(message.getEncodedSize() == static_cast<int>(size));
    std::vector<uint8_t> again(size);
    FUZZ_CHECK(message.encode(again.data(), 0, static_cast<int>(size)) == static_cast<int>(size));
    FUZZ_CHECK(std::equal(again.begin(), again.end(), data));
  }
}

// The controller's mode receiver: what its checked decoder takes has each count 0 or the arm's and
// finite numbers; what the receiver passes on is a LawSettings sized for the arm, which
// Controller::set_law judges (bounds, definiteness, limits).
void judge_a_mode(Readers& r, const uint8_t* message, int bytes) {
  control_mode_t mode;
  if (messages::decode_checked(message, size_t(bytes), mode, r.n, messages::Finite::Required).empty()) {
    FUZZ_CHECK(sized_for_its_counts(mode));
    FUZZ_CHECK((mode.num_joints == 0 || mode.num_joints == r.n) && (mode.num_posture == 0 || mode.num_posture == r.n));
    FUZZ_CHECK(all_finite(mode.joint_stiffness) && all_finite(mode.joint_damping) &&
               all_finite(mode.nullspace_posture) && std::isfinite(mode.damping_ratio) &&
               all_finite(&mode.cartesian_stiffness[0][0], 36) && all_finite(mode.stiffness_frame_position, 3) &&
               all_finite(mode.stiffness_frame_quaternion, 4) && std::isfinite(mode.nullspace_stiffness));
  } else {
    FUZZ_CHECK(!r.mode_receiver.receive(message, size_t(bytes)).empty());  // refused by the same decoder
    return;
  }
  if (!r.mode_receiver.receive(message, size_t(bytes)).empty()) return;
  LawSettings law(r.n);
  FUZZ_CHECK(r.laws.pop(law));
  FUZZ_CHECK(law.joint_stiffness.size() == r.n && law.joint_damping.size() == r.n &&
             law.nullspace_posture.size() == r.n);
  FUZZ_CHECK(law.joint_stiffness.allFinite() && law.joint_damping.allFinite() &&
             law.cartesian_stiffness.allFinite() && law.T_tip_frame.matrix().allFinite() &&
             law.nullspace_posture.allFinite());
  r.controller.set_law(law, r.now_ns);
}

// The controller's payload receiver: what it passes on is a physical body (payload_problem), so the
// daemon's worker builds the model that carries it without a throw; the controller then controls
// with that model.
void judge_a_payload(Readers& r, const uint8_t* message, int bytes) {
  if (!r.payload_receiver.receive(message, size_t(bytes)).empty()) return;
  Payload payload;
  FUZZ_CHECK(r.payloads.read(payload));
  FUZZ_CHECK(std::isfinite(payload.mass) && payload.mass >= 0.0 && payload.centre.allFinite() &&
             payload.inertia.allFinite());
  FUZZ_CHECK(payload_problem(payload).empty());
  std::unique_ptr<RobotModel> model;
  try {
    model = std::make_unique<RobotModel>(with_payload(r.model, payload));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "with_payload threw for a payload the receiver took: %s\n", e.what());
    FUZZ_CHECK(false);
  }
  FUZZ_CHECK(model->dof() == r.n);
  r.controller.set_model(*model);
  r.loaded = std::move(model);  // the previous model is released only once the controller holds this one
}

// A datagram the direct Bus reads: what it takes is LCM's small-message format, its channel and
// payload inside the datagram, end to end; the payload then goes where the state channel's would.
void judge_a_datagram(Readers& r, const uint8_t* data, size_t size) {
  LcmFragment fragment;
  if (parse_lcm_fragment(data, size, fragment)) {
    // A fragment lies inside its message; a message put together is exactly its announced size,
    // on a channel; a sender has one message in the works at most.
    FUZZ_CHECK(fragment.number < fragment.count && uint64_t{fragment.offset} + fragment.size <= fragment.message_size);
    FragmentAssembler::Message whole;
    std::vector<FragmentAssembler::Loss> losses;
    if (r.fragments.add(data[5] % 4, data, size, r.now_ns, whole, losses)) {
      FUZZ_CHECK(whole.payload.size() == fragment.message_size && !whole.channel.empty());
    }
    for (const auto& loss : losses) FUZZ_CHECK(!loss.why.empty());
    r.fragments.expire(r.now_ns, losses);
    FUZZ_CHECK(r.fragments.pending() <= 4);  // one message at most per sender
    return;
  }
  LcmDatagram datagram;
  if (!parse_lcm_datagram(data, size, datagram)) return;
  FUZZ_CHECK(size >= 9 && data[0] == 'L' && data[1] == 'C' && data[2] == '0' && data[3] == '2');
  const auto* channel = reinterpret_cast<const uint8_t*>(datagram.channel);
  FUZZ_CHECK(channel == data + 8);
  const size_t length = std::strlen(datagram.channel);
  FUZZ_CHECK(length <= 63);
  FUZZ_CHECK(datagram.payload == channel + length + 1);
  FUZZ_CHECK(datagram.payload + datagram.payload_size == data + size);
  if (r.state_receiver.receive(datagram.payload, datagram.payload_size, r.now_ns).empty()) {
    JointState state(r.n);
    FUZZ_CHECK(r.states.read(state));
    FUZZ_CHECK(state.q.allFinite() && state.qd.allFinite());
  }
}

// The controller's trajectory receiver: what it passes on is the arm's joints, each named once, in
// its order, at most Waypoints::kMaxPoints finite waypoints; Controller::set_trajectory judges the
// times, the limits and the tolerances, and whatever it takes keeps the reference within them.
void judge_a_trajectory(Readers& r, const uint8_t* message, int bytes) {
  if (!r.trajectory_receiver.receive(message, size_t(bytes)).empty()) return;
  motion::Waypoints w(r.n);
  FUZZ_CHECK(r.trajectories.pop(w));
  FUZZ_CHECK(w.count >= 1 && w.count <= motion::Waypoints::kMaxPoints);
  FUZZ_CHECK(w.time.head(w.count).allFinite() && w.q.leftCols(w.count).allFinite() &&
             w.qd.leftCols(w.count).allFinite() && w.qdd.leftCols(w.count).allFinite());
  if (r.controller.set_trajectory(w, r.now_ns)) {
    FUZZ_CHECK(r.controller.trajectory().outcome == TrajectoryProgress::kActive);
    FUZZ_CHECK(r.controller.trajectory().scale >= 1.0);
  }
}

// The scene receiver's decoder: what it takes keeps every rule of a scene (scene_problem), within
// the message's caps; encoded again and decoded it is the same scene; what it refuses leaves the
// scene in force as it was, with a reason. It never throws.
void judge_a_scene(const uint8_t* message, size_t bytes) {
  static geometry::Scene in_force;  // across inputs, as the daemon keeps its scene
  const size_t objects = in_force.objects.size(), planes = in_force.planes.size();
  char error[256];
  if (!decode_scene(message, bytes, in_force, error, sizeof error)) {
    FUZZ_CHECK(error[0] != '\0');
    FUZZ_CHECK(in_force.objects.size() == objects && in_force.planes.size() == planes);
    return;
  }
  FUZZ_CHECK(error[0] == '\0');
  FUZZ_CHECK(geometry::scene_problem(in_force).empty());
  FUZZ_CHECK(in_force.objects.size() <= size_t(scene_t::MAX_OBJECTS));
  FUZZ_CHECK(in_force.planes.size() <= size_t(scene_t::MAX_PLANES + 6 * scene_t::MAX_BOXES));
  for (const auto& object : in_force.objects) {
    FUZZ_CHECK(object.shape.vertices.size() <= size_t(scene_t::MAX_HULL_VERTICES));
    Vector3d centre;
    double radius = 0.0;
    geometry::bounding_sphere(object.shape, centre, radius);  // what Proximity computes once per scene
    FUZZ_CHECK(centre.allFinite() && std::isfinite(radius) && radius > 0.0);
  }
  scene_t again;
  try {
    again = encode_scene(in_force);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "encode_scene threw for a scene decode_scene took: %s\n", e.what());
    FUZZ_CHECK(false);
  }
  std::vector<uint8_t> encoded(size_t(again.getEncodedSize()));
  FUZZ_CHECK(again.encode(encoded.data(), 0, int(encoded.size())) == int(encoded.size()));
  geometry::Scene back;
  const bool taken = decode_scene(encoded.data(), encoded.size(), back, error, sizeof error);
  if (!taken) std::fprintf(stderr, "a scene taken, encoded again, is refused: %s\n", error);
  FUZZ_CHECK(taken);
  FUZZ_CHECK(back.objects.size() == in_force.objects.size() && back.planes.size() == in_force.planes.size());
  for (size_t k = 0; k < back.objects.size(); ++k) {
    FUZZ_CHECK(back.objects[k].name == in_force.objects[k].name);
    FUZZ_CHECK(back.objects[k].shape.kind == in_force.objects[k].shape.kind);
  }
  for (size_t k = 0; k < back.planes.size(); ++k) FUZZ_CHECK(back.planes[k].name == in_force.planes[k].name);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Readers* readers = new Readers();  // lives for the process, as in the daemon
  if (size == 0) return 0;
  Readers& r = *readers;
  const uint8_t* message = data + 1;
  const int bytes = static_cast<int>(size - 1);
  switch (data[0] % 16) {
    case 0:
      if (r.state_receiver.receive(message, size_t(bytes), r.now_ns).empty()) {
        JointState state(r.n);
        FUZZ_CHECK(r.states.read(state));
        FUZZ_CHECK(state.q.size() == r.n && state.q.allFinite() && state.qd.allFinite());
        r.state = state;
        r.have_state = true;
      }
      break;
    case 1:
      if (r.target_receiver.receive(message, size_t(bytes)).empty()) {
        Target target(r.n);
        FUZZ_CHECK(r.targets.pop(target));
        FUZZ_CHECK(target.num_joints >= 0 && target.num_joints <= r.n);
        r.controller.set_target(target, r.now_ns);  // judges the meaning: limits, duration, finiteness
      }
      break;
    case 2: {
      const int64_t rejected = r.commands.rejected();
      r.commands.receive(message, size_t(bytes));
      if (r.commands.rejected() == rejected) {
        const plant::Command& command = r.commands.take();
        FUZZ_CHECK(command.torque.size() == r.n);
        FUZZ_CHECK(command.torque.allFinite());
      }
      break;
    }
    case 4:
      judge_the_command_watch(r, message, bytes);
      break;
    case 5:
      judge_a_mode(r, message, bytes);
      break;
    case 6:
      judge_a_payload(r, message, bytes);
      break;
    case 7:
      judge_a_datagram(r, message, size_t(bytes));
      break;
    case 8:
      judge_a_trajectory(r, message, bytes);
      break;
    case 9:
      if (r.setpoint_receiver.receive(message, size_t(bytes)).empty()) {
        Setpoint setpoint(r.n);
        FUZZ_CHECK(r.setpoints.pop(setpoint));
        FUZZ_CHECK(setpoint.q.size() == r.n && setpoint.q.allFinite() && setpoint.qd.allFinite());
        r.controller.set_setpoint(setpoint, r.now_ns);  // orders, clamps and follows it within the limits
      }
      break;
    case 10:
      if (r.jog_receiver.receive(message, size_t(bytes)).empty()) {
        Jog jog(r.n);
        FUZZ_CHECK(r.jogs.pop(jog));
        FUZZ_CHECK(jog.joint_velocity.size() == r.n && jog.joint_velocity.allFinite() && jog.twist.allFinite());
        r.controller.set_jog(jog, r.now_ns);  // judges kind, frame and order; jogs within the limits
      }
      break;
    case 11:
      if (r.tip_setpoint_receiver.receive(message, size_t(bytes)).empty()) {
        TipSetpoint setpoint;
        FUZZ_CHECK(r.tip_setpoints.pop(setpoint));
        FUZZ_CHECK(setpoint.position.allFinite() && setpoint.quaternion.allFinite() && setpoint.twist.allFinite());
        r.controller.set_tip_setpoint(setpoint, r.now_ns);  // judges the quaternion and the order
      }
      break;
    case 12:
      judge_drake<drake::lcmt_iiwa_status>(message, size - 1, r.n);
      judge_drake<drake::lcmt_iiwa_command>(message, size - 1, r.n);
      judge_drake<drake::lcmt_panda_status>(message, size - 1, r.n);
      judge_drake<drake::lcmt_panda_command>(message, size - 1, r.n);
      judge_a_drake_status<drake::lcmt_iiwa_command>(r, r.iiwa_reader, r.iiwa_writer, message, size - 1);
      judge_a_drake_status<drake::lcmt_panda_command>(r, r.panda_reader, r.panda_writer, message, size - 1);
      break;
    case 13:
      judge_a_scene(message, size - 1);
      break;
    default: {
      decode_as<robot_state_t>(message, size - 1);
      decode_as<joint_torque_command_t>(message, size - 1);
      decode_as<arm_target_t>(message, size - 1);
      decode_as<controller_status_t>(message, size - 1);
      decode_as<control_mode_t>(message, size - 1);
      decode_as<payload_t>(message, size - 1);
      decode_as<joint_trajectory_t>(message, size - 1);
      decode_as<joint_setpoint_t>(message, size - 1);
      decode_as<jog_command_t>(message, size - 1);
      decode_as<tip_setpoint_t>(message, size - 1);
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
