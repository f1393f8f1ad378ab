// The protocols at the edge (controller/transport/protocol.hpp): their names and defaults, the sequence Drake's
// statuses lack, and each translation on real bytes — a message built by hand, encoded by lcm-gen,
// read back by the protocol's checked decoder and translated — with Drake's sign conventions and the
// overlay's subtraction of g(q) asserted exactly.
#include <gtest/gtest.h>

#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cstdint>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <limits>
#include <string>
#include <vector>

#include "controller/transport/protocol.hpp"
#include "lcmtypes/checked.hpp"
#include "support/allocation_counter.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::AllocationCounter;

constexpr int kJoints = 7;
constexpr int64_t kMs = 1'000'000;

template <class Message>
std::vector<uint8_t> encode(const Message& message) {
  std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
  EXPECT_EQ(message.encode(bytes.data(), 0, int(bytes.size())), int(bytes.size()));
  return bytes;
}

// n values that differ from each other and from 0, with a sign change; `scale` tells fields apart.
std::vector<double> values(int n, double scale) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(scale * (i % 2 == 0 ? 1.0 : -1.0) * (0.1 + i) / 3.0);
  return v;
}

VectorXd vector(const std::vector<double>& v) { return Eigen::Map<const VectorXd>(v.data(), Eigen::Index(v.size())); }

drake::lcmt_iiwa_status iiwa_status(int64_t utime) {
  drake::lcmt_iiwa_status m;
  m.utime = utime;
  m.num_joints = kJoints;
  m.joint_position_measured = values(kJoints, 1.0);
  m.joint_velocity_estimated = values(kJoints, 2.0);
  m.joint_position_commanded = values(kJoints, 3.0);
  m.joint_position_ipo = std::vector<double>(kJoints, std::numeric_limits<double>::quiet_NaN());
  m.joint_torque_measured = values(kJoints, 50.0);
  m.joint_torque_commanded = values(kJoints, 60.0);
  m.joint_torque_external = values(kJoints, 7.0);
  return m;
}

drake::lcmt_panda_status panda_status(int64_t utime) {
  drake::lcmt_panda_status m;
  m.utime = utime;
  m.num_joints = kJoints;
  m.joint_position = values(kJoints, 1.0);
  m.joint_position_desired = values(kJoints, 1.5);
  m.joint_velocity = values(kJoints, 2.0);
  m.joint_velocity_desired = values(kJoints, 2.5);
  m.joint_acceleration_desired = values(kJoints, 3.0);
  m.joint_torque = values(kJoints, 40.0);
  m.joint_torque_desired = values(kJoints, 45.0);
  m.joint_torque_external = values(kJoints, 5.0);
  m.control_command_success_rate = 1.0;
  m.robot_mode = drake::lcmt_panda_status::kMove;
  m.robot_utime = 42'000;
  m.control_mode = drake::lcmt_panda_status::CONTROL_MODE_TORQUE;
  return m;
}

// The law's torque τ and gravity's g(q), as hand-set numbers (the translations take them as given).
const VectorXd& tau() {
  static const VectorXd v = (VectorXd(kJoints) << 12.5, -30.25, 4.0, 18.75, -1.5, 2.25, -0.125).finished();
  return v;
}
const VectorXd& gravity() {
  static const VectorXd v = (VectorXd(kJoints) << 0.0, -28.0, 0.5, 20.0, 0.75, 1.25, 0.0).finished();
  return v;
}

// Reads one status with `reader` into a fresh state: "" or why it was refused.
std::string read(StatusReader& reader, const std::vector<uint8_t>& bytes, JointState& state, int64_t arrival_ns = 0) {
  return reader.read(bytes.data(), bytes.size(), arrival_ns, state);
}

TEST(Protocol, NamesDefaultsAndChannels) {
  for (const Protocol p : {Protocol::kChasles, Protocol::kDrakeIiwa, Protocol::kDrakePanda}) {
    Protocol back = p == Protocol::kChasles ? Protocol::kDrakePanda : Protocol::kChasles;
    ASSERT_TRUE(parse_protocol(to_string(p), back)) << to_string(p);
    EXPECT_EQ(back, p);
  }
  EXPECT_STREQ(to_string(Protocol::kChasles), "chasles");
  EXPECT_STREQ(to_string(Protocol::kDrakeIiwa), "drake-iiwa");
  EXPECT_STREQ(to_string(Protocol::kDrakePanda), "drake-panda");
  Protocol unchanged = Protocol::kDrakeIiwa;
  for (const char* bad : {"", "drake", "Drake-iiwa", "iiwa", "drake-panda ", "chasles2"}) {
    EXPECT_FALSE(parse_protocol(bad, unchanged)) << bad;
  }
  EXPECT_EQ(unchanged, Protocol::kDrakeIiwa);

  TorqueSemantics semantics = TorqueSemantics::kFull;
  EXPECT_TRUE(parse_torque_semantics("overlay", semantics));
  EXPECT_EQ(semantics, TorqueSemantics::kOverlay);
  EXPECT_TRUE(parse_torque_semantics("full", semantics));
  EXPECT_EQ(semantics, TorqueSemantics::kFull);
  EXPECT_FALSE(parse_torque_semantics("gravity", semantics));
  EXPECT_STREQ(to_string(TorqueSemantics::kOverlay), "overlay");
  EXPECT_STREQ(to_string(TorqueSemantics::kFull), "full");
  IiwaPositions positions = IiwaPositions::kNone;
  EXPECT_TRUE(parse_iiwa_positions("measured", positions));
  EXPECT_EQ(positions, IiwaPositions::kMeasured);
  EXPECT_TRUE(parse_iiwa_positions(to_string(IiwaPositions::kNone), positions));
  EXPECT_EQ(positions, IiwaPositions::kNone);
  EXPECT_FALSE(parse_iiwa_positions("commanded", positions));

  // The drivers add g(q) (the iiwa's, Drake's simulation in torque-only mode) or leave gravity to
  // libfranka (the Panda's); chasles's plant adds nothing.
  EXPECT_EQ(default_torque_semantics(Protocol::kChasles), TorqueSemantics::kFull);
  EXPECT_EQ(default_torque_semantics(Protocol::kDrakeIiwa), TorqueSemantics::kOverlay);
  EXPECT_EQ(default_torque_semantics(Protocol::kDrakePanda), TorqueSemantics::kOverlay);

  EXPECT_EQ(default_channels(Protocol::kChasles).status, "CHASLES_STATE");
  EXPECT_EQ(default_channels(Protocol::kChasles, "ARM2_").command, "ARM2_COMMAND");
  EXPECT_EQ(default_channels(Protocol::kDrakeIiwa).status, "IIWA_STATUS");
  EXPECT_EQ(default_channels(Protocol::kDrakeIiwa, "ARM2_").command, "IIWA_COMMAND");
  EXPECT_EQ(default_channels(Protocol::kDrakePanda).status, "PANDA_STATUS");
  EXPECT_EQ(default_channels(Protocol::kDrakePanda).command, "PANDA_COMMAND");

  EXPECT_EQ(nominal_status_period(Protocol::kDrakeIiwa), 0.005);  // 200 Hz
  EXPECT_EQ(nominal_status_period(Protocol::kDrakePanda), 0.001);
  EXPECT_EQ(nominal_status_period(Protocol::kChasles), 0.0);
}

TEST(Protocol, SequenceNumbersStatusesByArrivalAndRefusesDuplicateAndStaleOnes) {
  using V = StatusSequence::Verdict;
  StatusSequence s;
  EXPECT_EQ(s.seq(), -1);
  EXPECT_EQ(s.judge(0), V::kNext) << "Drake's simulation starts at utime 0";
  EXPECT_EQ(s.seq(), 0);
  EXPECT_EQ(s.judge(5000), V::kNext);
  EXPECT_EQ(s.seq(), 1);
  EXPECT_EQ(s.judge(5000), V::kDuplicate);
  EXPECT_EQ(s.judge(4999), V::kStale);
  EXPECT_EQ(s.seq(), 1);
  EXPECT_EQ(s.last_utime(), 5000);
  EXPECT_EQ(s.judge(25'000), V::kNext) << "a gap is lost statuses, not a refusal";
  EXPECT_EQ(s.seq(), 2);

  // A replay of old statuses interleaved with the live ones never restarts the count.
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(s.judge(1000 + 5000 * k), V::kStale) << k;
    EXPECT_EQ(s.judge(30'000 + 5000 * k), V::kNext) << k;
  }
  EXPECT_EQ(s.seq(), 12);
  const int64_t live = s.last_utime();

  // Stale statuses that do not rise are not a new sender.
  EXPECT_EQ(s.judge(10), V::kStale);
  EXPECT_EQ(s.judge(10), V::kStale);
  EXPECT_EQ(s.judge(5), V::kStale);
  EXPECT_EQ(s.last_utime(), live);

  // A simulation started again: kRestartRun rising statuses before the last one taken. The third is
  // taken and numbered 0; the next follows it.
  EXPECT_EQ(StatusSequence::kRestartRun, 3);
  EXPECT_EQ(s.judge(0), V::kStale);
  EXPECT_EQ(s.judge(5000), V::kStale);
  EXPECT_EQ(s.judge(10'000), V::kRestart);
  EXPECT_EQ(s.seq(), 0);
  EXPECT_EQ(s.last_utime(), 10'000);
  EXPECT_EQ(s.judge(15'000), V::kNext);
  EXPECT_EQ(s.seq(), 1);
}

// drake-iiwa-driver stamps utime −1 until its clock sync has 200 samples: no state before then, and
// the first synchronised status is the first state.
TEST(Protocol, SequenceWaitsForATime) {
  using V = StatusSequence::Verdict;
  StatusSequence s;
  for (int k = 0; k < 5; ++k) EXPECT_EQ(s.judge(-1), V::kUntimed) << k;
  EXPECT_EQ(s.seq(), -1);
  EXPECT_EQ(s.judge(1'790'000'000'000'000), V::kNext);
  EXPECT_EQ(s.seq(), 0);
  EXPECT_EQ(s.judge(-1), V::kUntimed) << "not stale, and no step toward a restart";
  EXPECT_EQ(s.judge(-1), V::kUntimed);
  EXPECT_EQ(s.judge(-1), V::kUntimed);
  EXPECT_EQ(s.judge(1'790'000'000'005'000), V::kNext);
  EXPECT_EQ(s.seq(), 1);

  StatusReader reader(Protocol::kDrakeIiwa, kJoints);
  JointState state(kJoints);
  EXPECT_EQ(read(reader, encode(iiwa_status(-1)), state),
            "untimed: utime -1 (the driver's clock is not synchronised yet)");
  EXPECT_EQ(reader.untimed(), 1);
  EXPECT_EQ(state.seq, -1) << "untouched";
}

// iiwa: positions and velocities as they are; joint_torque_measured negated into the state's
// effort, joint_torque_external as it is; joint_position_ipo may be NaN.
TEST(Protocol, IiwaStatusBecomesTheControllersStateWithDrakesSigns) {
  StatusReader reader(Protocol::kDrakeIiwa, kJoints);
  const drake::lcmt_iiwa_status m = iiwa_status(1'790'000'000'005'000);
  JointState state(kJoints);
  ASSERT_EQ(read(reader, encode(m), state, 77 * kMs), "");
  EXPECT_EQ(state.seq, 0);
  EXPECT_EQ(state.utime, m.utime);
  EXPECT_EQ(state.arrival_ns, 77 * kMs);
  for (int i = 0; i < kJoints; ++i) {
    const auto k = size_t(i);
    EXPECT_EQ(state.q[i], m.joint_position_measured[k]) << i;
    EXPECT_EQ(state.qd[i], m.joint_velocity_estimated[k]) << i;
    EXPECT_EQ(state.effort[i], -m.joint_torque_measured[k]) << i;
    EXPECT_EQ(reader.tau_ext()[i], m.joint_torque_external[k]) << i;
  }
  // The next status is the next state; the same again, or an older one, is refused and leaves the
  // state as it was.
  ASSERT_EQ(read(reader, encode(iiwa_status(m.utime + 5000)), state, 82 * kMs), "");
  EXPECT_EQ(state.seq, 1);
  EXPECT_EQ(state.utime, m.utime + 5000);
  EXPECT_EQ(read(reader, encode(iiwa_status(m.utime + 5000)), state, 87 * kMs),
            "a duplicate: utime 1790000000010000 again");
  EXPECT_EQ(read(reader, encode(iiwa_status(m.utime)), state, 88 * kMs),
            "stale: utime 1790000000005000 is 5000 µs before the last status taken");
  EXPECT_EQ(state.seq, 1);
  EXPECT_EQ(state.arrival_ns, 82 * kMs);
  EXPECT_EQ(reader.duplicates(), 1);
  EXPECT_EQ(reader.stale(), 1);
  EXPECT_EQ(reader.restarts(), 0);

  // What the checked decoder refuses never reaches the state.
  drake::lcmt_iiwa_status nan = iiwa_status(m.utime + 10'000);
  nan.joint_velocity_estimated[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(read(reader, encode(nan), state), "with non-finite joint_velocity_estimated");
  EXPECT_EQ(read(reader, encode(panda_status(m.utime + 10'000)), state), "not a lcmt_iiwa_status (wrong fingerprint)");
  drake::lcmt_iiwa_status six = iiwa_status(m.utime + 10'000);
  six.num_joints = 6;
  for (auto* v : {&six.joint_position_measured, &six.joint_velocity_estimated, &six.joint_position_commanded,
                  &six.joint_position_ipo, &six.joint_torque_measured, &six.joint_torque_commanded,
                  &six.joint_torque_external}) {
    v->pop_back();
  }
  EXPECT_EQ(read(reader, encode(six), state), "for 6 joints; the arm has 7");
  EXPECT_EQ(state.seq, 1);
  EXPECT_EQ(state.utime, m.utime + 5000);
}

// Panda: positions, velocities and tau_J as they are; tau_ext_hat_filtered negated.
TEST(Protocol, PandaStatusBecomesTheControllersStateWithDrakesSigns) {
  StatusReader reader(Protocol::kDrakePanda, kJoints);
  const drake::lcmt_panda_status m = panda_status(1'790'000'000'001'000);
  JointState state(kJoints);
  ASSERT_EQ(read(reader, encode(m), state, 5 * kMs), "");
  EXPECT_EQ(state.seq, 0);
  EXPECT_EQ(state.utime, m.utime) << "the host's utime, which a command echoes; not robot_utime";
  EXPECT_EQ(state.arrival_ns, 5 * kMs);
  for (int i = 0; i < kJoints; ++i) {
    const auto k = size_t(i);
    EXPECT_EQ(state.q[i], m.joint_position[k]) << i;
    EXPECT_EQ(state.qd[i], m.joint_velocity[k]) << i;
    EXPECT_EQ(state.effort[i], m.joint_torque[k]) << i;
    EXPECT_EQ(reader.tau_ext()[i], -m.joint_torque_external[k]) << i;
  }
  EXPECT_EQ(read(reader, encode(m), state, 6 * kMs), "a duplicate: utime 1790000000001000 again");
  EXPECT_EQ(read(reader, encode(iiwa_status(m.utime + 1000)), state), "not a lcmt_panda_status (wrong fingerprint)");
  ASSERT_EQ(read(reader, encode(panda_status(m.utime + 1000)), state, 7 * kMs), "");
  EXPECT_EQ(state.seq, 1);
}

// The free functions alone, on the messages themselves.
TEST(Protocol, TranslationsAreTheFunctionsOfTheirFields) {
  const drake::lcmt_iiwa_status iiwa = iiwa_status(5000);
  JointState state(kJoints);
  VectorXd tau_ext(kJoints);
  state_from_iiwa(iiwa, 41, 9, state, tau_ext);
  EXPECT_EQ(state.seq, 41);
  EXPECT_EQ(state.arrival_ns, 9);
  EXPECT_EQ(state.effort, VectorXd(-vector(iiwa.joint_torque_measured)));
  EXPECT_EQ(tau_ext, vector(iiwa.joint_torque_external));
  const drake::lcmt_panda_status panda = panda_status(6000);
  state_from_panda(panda, 42, 10, state, tau_ext);
  EXPECT_EQ(state.seq, 42);
  EXPECT_EQ(state.utime, 6000);
  EXPECT_EQ(state.effort, vector(panda.joint_torque));
  EXPECT_EQ(tau_ext, VectorXd(-vector(panda.joint_torque_external)));

  double out[kJoints];
  torque_for_receiver(tau(), gravity(), TorqueSemantics::kOverlay, out);
  for (int i = 0; i < kJoints; ++i) EXPECT_EQ(out[i], tau()[i] - gravity()[i]) << i;
  torque_for_receiver(tau(), gravity(), TorqueSemantics::kFull, out);
  for (int i = 0; i < kJoints; ++i) EXPECT_EQ(out[i], tau()[i]) << i;
  // The numbers themselves, for the first joints: 12.5 − 0, −30.25 − (−28), 4 − 0.5.
  torque_for_receiver(tau(), gravity(), TorqueSemantics::kOverlay, out);
  EXPECT_EQ(out[0], 12.5);
  EXPECT_EQ(out[1], -2.25);
  EXPECT_EQ(out[2], 3.5);
}

// A state as a reader gives it: seq, utime, q.
JointState answered_state(int64_t utime) {
  JointState state(kJoints);
  state.seq = 17;
  state.utime = utime;
  state.q = vector(values(kJoints, 0.9));
  return state;
}

// iiwa commands on the wire, through the checked decoder a driver-side reader would use.
TEST(Protocol, IiwaCommandCarriesTheTorqueLessGravityAndThePositionsItsDriverNeeds) {
  const JointState state = answered_state(1'790'000'000'005'000);
  {
    SCOPED_TRACE("torque only, overlay (the default): num_joints 0, τ − g");
    CommandWriter writer(Protocol::kDrakeIiwa, kJoints, TorqueSemantics::kOverlay);
    writer.write(123, 456, state, tau(), gravity());
    drake::lcmt_iiwa_command c;
    ASSERT_EQ(messages::decode_checked(writer.bytes().data(), writer.bytes().size(), c, kJoints,
                                       messages::Finite::Required),
              "");
    EXPECT_EQ(c.utime, state.utime) << "the state's, on the driver's clock";
    EXPECT_EQ(c.num_joints, 0);
    ASSERT_EQ(c.num_torques, kJoints);
    for (int i = 0; i < kJoints; ++i) EXPECT_EQ(c.joint_torque[size_t(i)], tau()[i] - gravity()[i]) << i;
    EXPECT_EQ(writer.bytes().size(), 8u + 8 + 4 + 4 + 8 * kJoints);
  }
  {
    SCOPED_TRACE("with the measured positions, full torque");
    CommandWriter writer(Protocol::kDrakeIiwa, kJoints, TorqueSemantics::kFull, IiwaPositions::kMeasured);
    writer.write(123, 456, state, tau(), gravity());
    drake::lcmt_iiwa_command c;
    ASSERT_EQ(messages::decode_checked(writer.bytes().data(), writer.bytes().size(), c, kJoints,
                                       messages::Finite::Required),
              "");
    ASSERT_EQ(c.num_joints, kJoints);
    ASSERT_EQ(c.num_torques, kJoints);
    for (int i = 0; i < kJoints; ++i) {
      EXPECT_EQ(c.joint_position[size_t(i)], state.q[i]) << i;
      EXPECT_EQ(c.joint_torque[size_t(i)], tau()[i]) << i;
    }
  }
}

TEST(Protocol, PandaCommandIsTorqueModesWithoutGravity) {
  const JointState state = answered_state(1'790'000'000'001'000);
  CommandWriter writer(Protocol::kDrakePanda, kJoints, default_torque_semantics(Protocol::kDrakePanda));
  writer.write(0, 0, state, tau(), gravity());
  drake::lcmt_panda_command c;
  ASSERT_EQ(messages::decode_checked(writer.bytes().data(), writer.bytes().size(), c, kJoints,
                                     messages::Finite::Required),
            "");
  // What drake-franka-driver's torque mode demands, else it throws: the torque bit alone, no
  // positions, no velocities, n torques; and a utime within 0.1 s of its clock.
  EXPECT_EQ(c.control_mode_expected, drake::lcmt_panda_status::CONTROL_MODE_TORQUE);
  EXPECT_EQ(c.control_mode_expected, 4);
  EXPECT_EQ(c.num_joint_position, 0);
  EXPECT_EQ(c.num_joint_velocity, 0);
  ASSERT_EQ(c.num_joint_torque, kJoints);
  EXPECT_EQ(c.utime, state.utime);
  for (int i = 0; i < kJoints; ++i) EXPECT_EQ(c.joint_torque[size_t(i)], tau()[i] - gravity()[i]) << i;

  CommandWriter full(Protocol::kDrakePanda, kJoints, TorqueSemantics::kFull);
  full.write(0, 0, state, tau(), gravity());
  ASSERT_EQ(messages::decode_checked(full.bytes().data(), full.bytes().size(), c, kJoints), "");
  for (int i = 0; i < kJoints; ++i) EXPECT_EQ(c.joint_torque[size_t(i)], tau()[i]) << i;
}

// chasles's own protocol through the same two ends: its seq, its state_seq, the whole torque.
TEST(Protocol, ChaslesProtocolIsItsOwnMessages) {
  StatusReader reader(Protocol::kChasles, kJoints);
  robot_state_t m;
  m.utime = 1'790'000'000'000'100;
  m.seq = 99;
  m.num_joints = kJoints;
  m.position = values(kJoints, 1.0);
  m.velocity = values(kJoints, 2.0);
  m.effort = values(kJoints, 3.0);
  JointState state(kJoints);
  ASSERT_EQ(read(reader, encode(m), state, 3 * kMs), "");
  EXPECT_EQ(state.seq, 99);
  EXPECT_EQ(state.utime, m.utime);
  EXPECT_EQ(state.effort, vector(m.effort)) << "not negated";
  EXPECT_EQ(reader.tau_ext(), VectorXd::Zero(kJoints));
  EXPECT_EQ(read(reader, encode(iiwa_status(1)), state), "not a robot_state_t (wrong fingerprint)");

  CommandWriter writer(Protocol::kChasles, kJoints, default_torque_semantics(Protocol::kChasles));
  writer.write(555, 12, state, tau(), gravity());
  joint_torque_command_t c;
  ASSERT_EQ(messages::decode_checked(writer.bytes().data(), writer.bytes().size(), c, kJoints), "");
  EXPECT_EQ(c.utime, 555);
  EXPECT_EQ(c.seq, 12);
  EXPECT_EQ(c.state_seq, 99);
  EXPECT_EQ(vector(c.torque), tau());
}

// Drake's conventions closed into a loop, as Drake's simulated iiwa driver in torque-only mode runs
// them: it applies g(q) + the torque commanded and reports that actuation, negated, as
// joint_torque_measured. So what chasles reads back as effort is the whole torque its law asked for.
TEST(Protocol, IiwaOverlayReadsBackAsTheLawsWholeTorque) {
  StatusReader reader(Protocol::kDrakeIiwa, kJoints);
  CommandWriter writer(Protocol::kDrakeIiwa, kJoints, TorqueSemantics::kOverlay);
  const JointState answered = answered_state(5000);
  writer.write(0, 0, answered, tau(), gravity());
  drake::lcmt_iiwa_command command;
  ASSERT_EQ(messages::decode_checked(writer.bytes().data(), writer.bytes().size(), command, kJoints), "");

  drake::lcmt_iiwa_status status = iiwa_status(10'000);  // the simulated driver's next status
  for (int i = 0; i < kJoints; ++i) {
    const double actuation = gravity()[i] + command.joint_torque[size_t(i)];
    status.joint_torque_measured[size_t(i)] = -actuation;
    status.joint_torque_commanded[size_t(i)] = -actuation;
  }
  JointState state(kJoints);
  ASSERT_EQ(read(reader, encode(status), state), "");
  for (int i = 0; i < kJoints; ++i) EXPECT_NEAR(state.effort[i], tau()[i], 1e-14) << i;
}

// The loop's side of a protocol allocates nothing once built: a status read, a command written.
TEST(Protocol, ReadingAndWritingAllocateNothing) {
  for (const Protocol p : {Protocol::kChasles, Protocol::kDrakeIiwa, Protocol::kDrakePanda}) {
    SCOPED_TRACE(to_string(p));
    std::vector<std::vector<uint8_t>> statuses;
    for (int k = 0; k < 20; ++k) {
      const int64_t utime = 1000 * (k + 1);
      if (p == Protocol::kDrakeIiwa) {
        statuses.push_back(encode(iiwa_status(utime)));
      } else if (p == Protocol::kDrakePanda) {
        statuses.push_back(encode(panda_status(utime)));
      } else {
        robot_state_t m;
        m.utime = utime;
        m.seq = k;
        m.num_joints = kJoints;
        m.position = m.velocity = m.effort = values(kJoints, 1.0);
        statuses.push_back(encode(m));
      }
    }
    StatusReader reader(p, kJoints);
    CommandWriter writer(p, kJoints, default_torque_semantics(p), IiwaPositions::kMeasured);
    JointState state(kJoints);
    int refused = 0;
    const VectorXd& law = tau();  // built on first use: before counting
    const VectorXd& g = gravity();
    AllocationCounter counter;
    for (const auto& bytes : statuses) {
      if (!reader.read(bytes.data(), bytes.size(), 0, state).empty()) ++refused;
      writer.write(state.utime, state.seq + 1, state, law, g);
    }
    const long allocations = counter.count();
    EXPECT_EQ(refused, 0);
    EXPECT_EQ(allocations, 0);
    EXPECT_EQ(state.utime, 20'000);
  }
}

// Drake's commands have no seq: our own are known by their bytes, once each; a replayed copy,
// another sender's command, junk, and ours once it has left the window are foreign.
TEST(Protocol, DigestWatchTellsOurOwnDrakeCommandsFromAnotherSenders) {
  SentDigests sent;
  DigestCommandWatch watch(sent);
  CommandWriter writer(Protocol::kDrakeIiwa, kJoints, TorqueSemantics::kOverlay);
  JointState state = answered_state(5000);
  writer.write(0, 0, state, tau(), gravity());
  const std::vector<uint8_t> first = writer.bytes();
  sent.record(first);
  writer.write(0, 0, state, tau(), gravity());
  sent.record(writer.bytes());  // the same bytes again: a second tick on the same state
  EXPECT_FALSE(watch.receive(first.data(), first.size())) << "ours, coming back";
  EXPECT_FALSE(watch.receive(first.data(), first.size())) << "the second of two identical commands";
  EXPECT_EQ(watch.first_utime(), -1) << "nothing foreign yet";
  EXPECT_TRUE(watch.receive(first.data(), first.size())) << "a third copy: a replay";
  EXPECT_EQ(watch.foreign(), 1);
  EXPECT_EQ(watch.first_utime(), 5000) << "the status the replayed command answers";

  // Another controller's command: another torque, same utime.
  drake::lcmt_iiwa_command other;
  other.utime = state.utime;
  other.num_joints = 0;
  other.num_torques = kJoints;
  other.joint_torque = values(kJoints, 3.0);
  const std::vector<uint8_t> theirs = encode(other);
  EXPECT_TRUE(watch.receive(theirs.data(), theirs.size()));
  const uint8_t junk[3] = {1, 2, 3};
  EXPECT_TRUE(watch.receive(junk, sizeof junk));
  EXPECT_EQ(watch.foreign(), 3);

  // kWindow commands later, the first one's record is gone.
  state.utime = 10'000;
  writer.write(0, 0, state, tau(), gravity());
  const std::vector<uint8_t> old = writer.bytes();
  sent.record(old);
  for (size_t k = 0; k < SentDigests::kWindow; ++k) {
    state.utime = 20'000 + int64_t(k);
    writer.write(0, 0, state, tau(), gravity());
    sent.record(writer.bytes());
  }
  EXPECT_TRUE(watch.receive(old.data(), old.size()));
  EXPECT_FALSE(watch.receive(writer.bytes().data(), writer.bytes().size())) << "the latest is still known";
  EXPECT_NE(SentDigests::digest(junk, 0), 0u);
  EXPECT_EQ(SentDigests::digest(junk, 0), 0xcbf29ce484222325u) << "FNV-1a's offset basis";
  EXPECT_EQ(SentDigests::digest("a", 1), 0xaf63dc4c8601ec8cu) << "FNV-1a of \"a\"";
}

// Recording a command allocates nothing: the loop does it every tick.
TEST(Protocol, RecordingADigestAllocatesNothing) {
  SentDigests sent;
  const std::vector<uint8_t> bytes(136, 7);
  AllocationCounter counter;
  for (int k = 0; k < 1000; ++k) sent.record(bytes);
  const long allocations = counter.count();
  EXPECT_EQ(allocations, 0);
}

}  // namespace
}  // namespace chasles::controller
