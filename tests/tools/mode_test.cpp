// chasles mode and chasles payload (its tests named mode.Payload*), run as real processes, heard
// by a subscriber in this process. The test binary runs inside its own network namespace
// (tools/netns.sh is its launcher, see CMakeLists.txt), so the multicast never leaves the machine.
// What is heard is decoded with the controller's checked decoder for the Panda's 7 joints, and
// must carry exactly what was asked. A refused mode or payload must exit 1 with one
// "chasles: mode: ..." (or "chasles: payload: ...") line and send nothing at all: after the
// refusals one good message is sent, and it must be the first and only one heard, so no fixed
// wait decides that nothing came.
#include <gtest/gtest.h>

#include <algorithm>
#include <chasles/control_mode_t.hpp>
#include <chasles/payload_t.hpp>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lcmtypes/checked.hpp"
#include "support/bus_listener.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;
using Bytes = std::vector<uint8_t>;
using Result = testing::RunResult;

constexpr char kPrefix[] = "TEST_";
constexpr int kJoints = 7;  // the Panda's

// Runs `chasles ARGS` without the caller's LCM_DEFAULT_URL; `env` entries ("NAME=value") are added.
Result run_cli(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  return testing::run_to_completion(concat({CHASLES_CLI}, args), "/dev/null", concat({"LCM_DEFAULT_URL"}, env));
}

// The raw bytes of every message `chasles` sent on `channel` of the test's bus.
struct Listener : testing::BusListener {
  explicit Listener(const std::string& channel) : BusListener(kLcmUrl, channel) {}
};

// As the controller's ModeReceiver and PayloadReceiver decode them.
control_mode_t decode_mode(const Bytes& bytes) {
  control_mode_t mode;
  EXPECT_EQ(messages::decode_checked(bytes.data(), bytes.size(), mode, kJoints, messages::Finite::Required), "");
  return mode;
}
payload_t decode_payload(const Bytes& bytes) {
  payload_t payload;
  EXPECT_EQ(
      messages::decode_checked(bytes.data(), bytes.size(), payload, messages::kAnyArm, messages::Finite::Required), "");
  return payload;
}

int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const std::vector<std::string> kWire = {"--lcm-url", kLcmUrl, "--channel-prefix", kPrefix};

// chasles mode LAW on the Panda (tip panda_hand), on the test's wire, with `args`.
std::vector<std::string> mode(const std::string& law, const std::vector<std::string>& args = {}) {
  return concat(concat({"mode", law, "--robot", data_path("panda.urdf"), "--tip", "panda_hand"}, kWire), args);
}
std::vector<std::string> payload(const std::vector<std::string>& args) {
  return concat(concat({"payload"}, kWire), args);
}

// A successful send: exit 0, nothing on stderr, one JSON line on stdout.
json sent_json(const Result& r) {
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  return r.exit_code == 0 ? json::parse(r.out) : json();
}

// Runs `args`, expects one message on `channel`, and returns its bytes and the JSON printed.
struct Sent {
  Bytes bytes;
  json out;
};
Sent send(const std::string& channel, const std::vector<std::string>& args) {
  Listener listener(channel);
  Sent sent;
  sent.out = sent_json(run_cli(args));
  const auto& received = listener.listen(2.0, 1);
  EXPECT_EQ(received.size(), 1u) << "nothing heard on " << channel;
  if (!received.empty()) sent.bytes = received[0];
  return sent;
}

void expect_identity_frame(const control_mode_t& m) {
  EXPECT_EQ(std::vector<double>(m.stiffness_frame_position, m.stiffness_frame_position + 3),
            std::vector<double>({0.0, 0.0, 0.0}));
  EXPECT_EQ(std::vector<double>(m.stiffness_frame_quaternion, m.stiffness_frame_quaternion + 4),
            std::vector<double>({1.0, 0.0, 0.0, 0.0}));
}

std::vector<double> row_major(const control_mode_t& m) {
  return std::vector<double>(&m.cartesian_stiffness[0][0], &m.cartesian_stiffness[0][0] + 36);
}

// A 6×6 diagonal, row-major.
std::vector<double> diagonal(const std::vector<double>& d) {
  std::vector<double> k(36, 0.0);
  for (size_t i = 0; i < 6; ++i) k[7 * i] = d[i];
  return k;
}

std::string joined(const std::vector<double>& values) {
  std::string text;
  for (const double x : values) text += (text.empty() ? "" : ",") + json(x).dump();
  return text;
}

TEST(mode, ComputedTorqueCarriesNoSettings) {
  const int64_t before = now_us();
  const Sent sent = send("TEST_MODE", mode("computed-torque"));
  const control_mode_t m = decode_mode(sent.bytes);
  EXPECT_EQ(m.law, control_mode_t::COMPUTED_TORQUE);
  EXPECT_EQ(m.num_joints, 0);
  EXPECT_EQ(m.num_posture, 0);
  EXPECT_EQ(m.damping_ratio, 1.0);
  EXPECT_EQ(row_major(m), std::vector<double>(36, 0.0));
  expect_identity_frame(m);
  EXPECT_EQ(m.nullspace_stiffness, 0.0);
  EXPECT_GE(m.utime, before);
  EXPECT_LE(m.utime, now_us());
  EXPECT_EQ(sent.out, json::parse(R"({"channel":"TEST_MODE","utime":)" + std::to_string(m.utime) +
                                  R"(,"law":"computed-torque"})"));
}

TEST(mode, JointImpedanceSendsOneStiffnessPerJoint) {
  const std::vector<double> K = {100, 200, 300, 400, 500, 600, 700};
  const Sent sent = send("TEST_MODE", mode("joint-impedance", {"--stiffness", "100,200,300,400,500,600,700",
                                                               "--damping-ratio", "0.7"}));
  const control_mode_t m = decode_mode(sent.bytes);
  EXPECT_EQ(m.law, control_mode_t::JOINT_IMPEDANCE);
  EXPECT_EQ(m.num_joints, kJoints);
  EXPECT_EQ(m.joint_stiffness, K);
  EXPECT_EQ(m.joint_damping, std::vector<double>(kJoints, 0.0));  // all 0: from the damping ratio
  EXPECT_EQ(m.damping_ratio, 0.7);
  EXPECT_EQ(m.num_posture, 0);
  EXPECT_EQ(sent.out["law"], "joint-impedance");
  EXPECT_EQ(sent.out["joint_names"][6], "panda_joint7");
  EXPECT_EQ(sent.out["joint_stiffness"].get<std::vector<double>>(), K);
  EXPECT_EQ(sent.out["damping_ratio"], 0.7);
  EXPECT_FALSE(sent.out.contains("joint_damping"));
}

TEST(mode, JointImpedanceWithOneStiffnessAndExplicitDamping) {
  const std::vector<double> D = {1, 2, 3, 4, 5, 6, 0};  // one joint undamped is the user's right
  const Sent sent = send("TEST_MODE", mode("joint-impedance", {"--stiffness", "300", "--damping", joined(D)}));
  const control_mode_t m = decode_mode(sent.bytes);
  EXPECT_EQ(m.num_joints, kJoints);
  EXPECT_EQ(m.joint_stiffness, std::vector<double>(kJoints, 300.0));
  EXPECT_EQ(m.joint_damping, D);
  EXPECT_EQ(sent.out["joint_damping"].get<std::vector<double>>(), D);
  EXPECT_FALSE(sent.out.contains("damping_ratio"));  // not read with explicit damping
}

TEST(mode, CartesianImpedanceSendsTheDiagonalFrameAndPosture) {
  const std::vector<double> posture = {0.1, -0.3, 0.2, -2.0, 0.0, 1.7, 0.8};
  const Sent sent =
      send("TEST_MODE", mode("cartesian-impedance", {"--translational", "800", "--rotational", "40", "--frame",
                                                     "0.01,-0.02,0.1,0.7071,0,0.7071,0", "--posture", joined(posture),
                                                     "--nullspace-stiffness", "20", "--damping-ratio", "0.8"}));
  const control_mode_t m = decode_mode(sent.bytes);
  EXPECT_EQ(m.law, control_mode_t::CARTESIAN_IMPEDANCE);
  EXPECT_EQ(m.num_joints, 0);
  EXPECT_EQ(row_major(m), diagonal({40, 40, 40, 800, 800, 800}));  // (ω, v): rotational first
  EXPECT_EQ(std::vector<double>(m.stiffness_frame_position, m.stiffness_frame_position + 3),
            std::vector<double>({0.01, -0.02, 0.1}));
  // Normalised, as the contract asks: typed with four decimals, its norm was 0.99999.
  const double* q = m.stiffness_frame_quaternion;
  EXPECT_NEAR(std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]), 1.0, 1e-15);
  EXPECT_NEAR(q[0], std::sqrt(0.5), 1e-15);
  EXPECT_EQ(q[0], q[2]);
  EXPECT_EQ(q[1], 0.0);
  EXPECT_EQ(q[3], 0.0);
  EXPECT_EQ(m.num_posture, kJoints);
  EXPECT_EQ(m.nullspace_posture, posture);
  EXPECT_EQ(m.nullspace_stiffness, 20.0);
  EXPECT_EQ(m.damping_ratio, 0.8);
  EXPECT_EQ(sent.out["nullspace_posture"].get<std::vector<double>>(), posture);
  EXPECT_EQ(sent.out["cartesian_stiffness"][3][3], 800.0);
  EXPECT_EQ(sent.out["stiffness_frame_quaternion"][0].get<double>(), q[0]);
  EXPECT_NEAR(sent.out["quaternion_input_norm"].get<double>(), 0.7071 * std::sqrt(2.0), 1e-15);
}

TEST(mode, CartesianImpedanceDefaults) {
  const Sent sent = send("TEST_MODE", mode("cartesian-impedance"));
  const control_mode_t m = decode_mode(sent.bytes);
  EXPECT_EQ(row_major(m), diagonal({50, 50, 50, 1000, 1000, 1000}));
  expect_identity_frame(m);
  EXPECT_EQ(m.num_posture, 0);  // the nullspace pulls toward the reference
  EXPECT_EQ(m.nullspace_stiffness, 10.0);
  EXPECT_EQ(m.damping_ratio, 1.0);
  EXPECT_FALSE(sent.out.contains("nullspace_posture"));
}

TEST(mode, CartesianStiffnessAsDiagonalOrFullMatrix) {
  const Sent diag = send("TEST_MODE", mode("cartesian-impedance", {"--cartesian-stiffness", "10,20,30,100,200,300",
                                                                   "--frame", "0,0,0.05"}));
  const control_mode_t d = decode_mode(diag.bytes);
  EXPECT_EQ(row_major(d), diagonal({10, 20, 30, 100, 200, 300}));
  EXPECT_EQ(d.stiffness_frame_position[2], 0.05);
  EXPECT_EQ(d.stiffness_frame_quaternion[0], 1.0);  // X,Y,Z alone: the tip frame's axes

  // Coupled rotation and translation (10 N/rad between ω_x and v_y), symmetric, positive definite.
  std::vector<double> K = diagonal({40, 40, 40, 800, 800, 800});
  K[0 * 6 + 4] = K[4 * 6 + 0] = 10.0;
  K[1 * 6 + 2] = K[2 * 6 + 1] = 5.0;
  const Sent full = send("TEST_MODE", mode("cartesian-impedance", {"--cartesian-stiffness", joined(K)}));
  EXPECT_EQ(row_major(decode_mode(full.bytes)), K);
}

TEST(mode, FreeDriveWithDefaultOrGivenDamping) {
  const control_mode_t plain = decode_mode(send("TEST_MODE", mode("free-drive")).bytes);
  EXPECT_EQ(plain.law, control_mode_t::FREE_DRIVE);
  EXPECT_EQ(plain.num_joints, 0);  // its default damping
  EXPECT_EQ(plain.num_posture, 0);

  const control_mode_t damped = decode_mode(send("TEST_MODE", mode("free-drive", {"--damping", "3"})).bytes);
  EXPECT_EQ(damped.num_joints, kJoints);
  EXPECT_EQ(damped.joint_damping, std::vector<double>(kJoints, 3.0));
  EXPECT_EQ(damped.joint_stiffness, std::vector<double>(kJoints, 0.0));
}

// Without --channel-prefix and --lcm-url: CHASLES_MODE and CHASLES_PAYLOAD, on $LCM_DEFAULT_URL.
TEST(mode, DefaultChannelsAndUrlFromTheEnvironment) {
  const std::vector<std::string> env = {std::string("LCM_DEFAULT_URL=") + kLcmUrl};
  {
    Listener listener("CHASLES_MODE");
    const json out = sent_json(
        run_cli({"mode", "computed-torque", "--robot", data_path("panda.urdf"), "--tip", "panda_hand"}, env));
    EXPECT_EQ(out["channel"], "CHASLES_MODE");
    EXPECT_EQ(listener.listen(2.0, 1).size(), 1u);
  }
  Listener listener("CHASLES_PAYLOAD");
  const json out = sent_json(run_cli({"payload", "--mass", "0"}, env));
  EXPECT_EQ(out["channel"], "CHASLES_PAYLOAD");
  EXPECT_EQ(listener.listen(2.0, 1).size(), 1u);
}

// Expects `args` to be refused: exit 1, one "chasles: <command>: " line naming the problem, nothing
// on stdout.
void expect_refused(const std::vector<std::string>& args, const std::string& needle) {
  const Result r = run_cli(args);
  const std::string start = "chasles: " + args[0] + ": ";
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err.rfind(start, 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
}

// After refusals heard by `listener`: one good message sent now must be the first and only one.
void expect_only(Listener& listener, const std::vector<std::string>& good) {
  const int64_t before = now_us();
  sent_json(run_cli(good));
  const auto& received = listener.listen(2.0, 1);
  ASSERT_EQ(received.size(), 1u) << "the good message was not heard";
  int64_t utime = 0;
  if (good[0] == "mode") utime = decode_mode(received[0]).utime;
  if (good[0] == "payload") utime = decode_payload(received[0]).utime;
  EXPECT_GE(utime, before) << "a refused " << good[0] << " was sent";
}

// Each with the controller's own words (law_problem, law_from_message), or the option's.
TEST(mode, BadValuesAreRefusedAndNothingIsSent) {
  Listener listener("TEST_MODE");
  const auto ji = [](const std::vector<std::string>& args) { return mode("joint-impedance", args); };
  const auto ci = [](const std::vector<std::string>& args) { return mode("cartesian-impedance", args); };

  // Not finite.
  expect_refused(ji({"--stiffness", "100,nan,100,100,100,100,100"}), "--stiffness: entry 1 ('nan') is not finite");
  expect_refused(ji({"--stiffness", "inf"}), "--stiffness: entry 0 ('inf') is not finite");
  expect_refused(ci({"--translational", "inf"}), "--translational: entry 0 ('inf') is not finite");
  expect_refused(ci({"--cartesian-stiffness", "10,10,nan,100,100,100"}), "entry 2 ('nan') is not finite");
  // Joint stiffness not positive, or over LawBounds::kMaxJointStiffness.
  expect_refused(ji({"--stiffness", "-100"}), "joint panda_joint1: stiffness -100 is not in (0, 5000]");
  expect_refused(ji({"--stiffness", "100,100,0,100,100,100,100"}),
                 "joint panda_joint3: stiffness 0 is not in (0, 5000]");
  expect_refused(ji({"--stiffness", "100,100,100,100,100,100,5000.5"}),
                 "joint panda_joint7: stiffness 5000.5 is not in (0, 5000]");
  expect_refused(ji({"--stiffness", "100", "--damping", "1,1,1,-1,1,1,1"}),
                 "joint panda_joint4: damping -1 is not finite and non-negative");
  expect_refused(ji({}), "joint-impedance needs --stiffness");
  // Cartesian stiffness over its bounds, not symmetric, not positive definite.
  expect_refused(ci({"--translational", "5001"}), "the Cartesian translational stiffness reaches 5001 N/m, over 5000");
  expect_refused(ci({"--rotational", "500.5"}), "the Cartesian rotational stiffness reaches 500.5 N*m/rad, over 500");
  expect_refused(ci({"--rotational", "0"}), "the Cartesian stiffness is not positive definite");
  expect_refused(ci({"--cartesian-stiffness", "50,50,50,1000,-1000,1000"}),
                 "the Cartesian stiffness is not positive definite");
  std::vector<double> asymmetric = diagonal({50, 50, 50, 1000, 1000, 1000});
  asymmetric[0 * 6 + 3] = 10.0;  // K[3][0] stays 0
  expect_refused(ci({"--cartesian-stiffness", joined(asymmetric)}), "the Cartesian stiffness is not symmetric");
  // Each diagonal block positive definite, the whole not: a coupling of 300 N/rad, 300² > 50 · 1000.
  std::vector<double> indefinite = diagonal({50, 50, 50, 1000, 1000, 1000});
  indefinite[0 * 6 + 3] = indefinite[3 * 6 + 0] = 300.0;
  expect_refused(ci({"--cartesian-stiffness", joined(indefinite)}), "the Cartesian stiffness is not positive definite");
  expect_refused(ci({"--cartesian-stiffness", "1,2,3,4,5"}), "--cartesian-stiffness has 5 entries; give 6");
  expect_refused(ci({"--nullspace-stiffness", "501"}), "nullspace stiffness 501 is not in [0, 500]");
  expect_refused(ci({"--nullspace-stiffness", "-1"}), "nullspace stiffness -1 is not in [0, 500]");
  // The stiffness frame.
  expect_refused(ci({"--frame", "0,0,0.1,0.5,0,0,0"}),
                 "stiffness_frame_quaternion (w, x, y, z) has norm 0.500000, not 1");
  expect_refused(ci({"--frame", "0,0,0.1,0,0,0,0"}), "has norm 0.000000, not 1");
  expect_refused(ci({"--frame", "1.5,0,0"}), "the stiffness frame is 1.5 m from the tip, over 1");
  expect_refused(ci({"--frame", "0,0,0.1,1,0"}), "--frame has 5 entries");
  // The posture: outside the limits (0 is outside panda_joint4's [-3.0718, -0.0698]), wrong length.
  expect_refused(ci({"--posture", "0,0,0,0,0,1,0"}),
                 "joint panda_joint4: nullspace posture 0 is outside its limits [-3.0718, -0.0698]");
  expect_refused(ci({"--posture", "0,0,0,-1,0,1"}), "--posture has 6 entries, expected 7");
  // A wrong number of joint values.
  expect_refused(ji({"--stiffness", "100,200,300"}), "--stiffness has 3 entries; give one for every joint or 7");
  expect_refused(ji({"--stiffness", "100", "--damping", "1,2,3,4,5,6,7,8"}), "--damping has 8 entries");
  // The damping ratio outside [0.1, 2].
  expect_refused(ji({"--stiffness", "100", "--damping-ratio", "2.5"}), "damping ratio 2.5 is outside [0.1, 2]");
  expect_refused(ci({"--damping-ratio", "0.05"}), "damping ratio 0.05 is outside [0.1, 2]");
  expect_refused(ci({"--damping-ratio", "x"}), "--damping-ratio: entry 0 ('x') is not a number");
  // Free drive's damping must be positive; all 0 would silently mean its default.
  expect_refused(mode("free-drive", {"--damping", "1,1,1,1,1,1,-1"}),
                 "joint panda_joint7: free-drive damping -1 must be positive and finite");
  expect_refused(mode("free-drive", {"--damping", "0"}), "--damping is 0 for every joint");
  // An unknown law; options the law does not read.
  expect_refused(mode("impedance"), "unknown law 'impedance' (laws: computed-torque, joint-impedance");
  expect_refused(ji({"--stiffness", "100", "--posture", "0,0,0,-1,0,1,0"}),
                 "--posture does not apply to joint-impedance (only to cartesian-impedance)");
  expect_refused(ci({"--stiffness", "100"}), "--stiffness does not apply to cartesian-impedance (only to "
                                             "joint-impedance)");
  expect_refused(mode("free-drive", {"--translational", "800"}), "--translational does not apply to free-drive");
  expect_refused(mode("computed-torque", {"--damping-ratio", "1"}),
                 "--damping-ratio does not apply to computed-torque");
  expect_refused(mode("computed-torque", {"--damping", "1"}), "--damping does not apply to computed-torque");

  expect_only(listener, mode("computed-torque"));
}

// Combinations that are never valid, and missing required arguments, are usage errors (exit 2).
TEST(mode, UsageErrorsExitTwo) {
  Listener listener("TEST_MODE");
  const auto usage = [&](const std::vector<std::string>& args, const std::string& needle) {
    const Result r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
  };
  usage(concat({"mode", "joint-impedance"}, concat(kWire, {"--stiffness", "100"})), "--robot");
  usage(concat({"mode", "--robot", data_path("panda.urdf"), "--tip", "panda_hand"}, kWire), "law");
  usage(mode("cartesian-impedance", {"--translational", "800", "--cartesian-stiffness", "1,1,1,1,1,1"}), "excludes");
  usage(mode("joint-impedance", {"--stiffness", "100", "--damping", "1", "--damping-ratio", "1"}), "excludes");
  usage(mode("computed-torque", {"--channel-prefix", "A.*"}), "--channel-prefix");
  usage(payload({}), "--mass");
  expect_only(listener, mode("computed-torque"));
}

TEST(mode, PayloadMassCentreAndInertiaAreSentExactly) {
  const int64_t before = now_us();
  const Sent sent =
      send("TEST_PAYLOAD", payload({"--mass", "1.5", "--com", "0.01,-0.02,0.08", "--inertia", "0.01,0.02,0.025"}));
  const payload_t p = decode_payload(sent.bytes);
  EXPECT_EQ(p.mass, 1.5);
  EXPECT_EQ(std::vector<double>(p.centre_of_mass, p.centre_of_mass + 3), std::vector<double>({0.01, -0.02, 0.08}));
  EXPECT_EQ(std::vector<double>(&p.inertia[0][0], &p.inertia[0][0] + 9),
            std::vector<double>({0.01, 0, 0, 0, 0.02, 0, 0, 0, 0.025}));
  EXPECT_GE(p.utime, before);
  EXPECT_EQ(sent.out["channel"], "TEST_PAYLOAD");
  EXPECT_EQ(sent.out["utime"], p.utime);
  EXPECT_EQ(sent.out["mass"], 1.5);
  EXPECT_EQ(sent.out["inertia"][2][2], 0.025);

  // Products of inertia (IXY, IXZ, IYZ) fill both sides of the symmetric matrix.
  const payload_t full = decode_payload(
      send("TEST_PAYLOAD", payload({"--mass", "2", "--inertia", "0.02,0.02,0.03,0.001,-0.002,0.003"})).bytes);
  EXPECT_EQ(std::vector<double>(&full.inertia[0][0], &full.inertia[0][0] + 9),
            std::vector<double>({0.02, 0.001, -0.002, 0.001, 0.02, 0.003, -0.002, 0.003, 0.03}));
  EXPECT_EQ(std::vector<double>(full.centre_of_mass, full.centre_of_mass + 3), std::vector<double>({0, 0, 0}));
}

TEST(mode, PayloadMassZeroRemovesIt) {
  const payload_t p = decode_payload(send("TEST_PAYLOAD", payload({"--mass", "0"})).bytes);
  EXPECT_EQ(p.mass, 0.0);
  EXPECT_EQ(std::vector<double>(p.centre_of_mass, p.centre_of_mass + 3), std::vector<double>(3, 0.0));
  EXPECT_EQ(std::vector<double>(&p.inertia[0][0], &p.inertia[0][0] + 9), std::vector<double>(9, 0.0));
}

// Each with payload_problem's words, or the option's.
TEST(mode, PayloadBadValuesAreRefusedAndNothingIsSent) {
  Listener listener("TEST_PAYLOAD");
  expect_refused(payload({"--mass", "-1"}), "mass -1 kg is negative");
  expect_refused(payload({"--mass", "nan"}), "--mass: entry 0 ('nan') is not finite");
  expect_refused(payload({"--mass", "1", "--com", "0,inf,0"}), "--com: entry 1 ('inf') is not finite");
  expect_refused(payload({"--mass", "1", "--inertia", "0.01,0.01,nan"}), "--inertia: entry 2 ('nan') is not finite");
  expect_refused(payload({"--mass", "1", "--inertia", "0.01,0.01,0.03"}), "break the triangle inequality");
  expect_refused(payload({"--mass", "1", "--inertia", "-0.01,0.01,0.01"}), "include a negative one");
  expect_refused(payload({"--mass", "1,2"}), "--mass takes one number; got 2");
  expect_refused(payload({"--mass", "1", "--com", "0,0"}), "--com has 2 entries; give X,Y,Z");
  expect_refused(payload({"--mass", "1", "--inertia", "1,1,1,0"}), "--inertia has 4 entries");
  expect_refused(payload({"--mass", "0", "--com", "0,0,0.1"}), "--mass 0 removes the payload");
  expect_only(listener, payload({"--mass", "1"}));
}

// An LCM that cannot start is one line, with LCM's own reason, and exit 1.
TEST(mode, LcmThatCannotStartIsAnError) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"mode", "computed-torque", "--robot", data_path("panda.urdf"), "--tip", "panda_hand"},
        std::vector<std::string>{"payload", "--mass", "1"}}) {
    const Result r = run_cli(concat(args, {"--lcm-url", "nosuchprovider://x"}));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("chasles: cannot start LCM on nosuchprovider://x", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("provider \"nosuchprovider\" not found"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

}  // namespace
}  // namespace chasles::testing
