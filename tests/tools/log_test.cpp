// chasles log export and plot on logs that lcm-logger really recorded. The test binary runs in a
// network namespace of its own (tools/netns.sh launches it), publishes known messages over LCM
// while lcm-logger records them, and checks that the export gives back exactly what was sent;
// then it damages copies of the log (cut short, overwritten, forged sizes, random bytes) and
// checks that what is readable still comes out, with an error naming the byte offset.
//
// `chasles log plot` is log_plot_test.cpp's, in the same binary; log_recording.hpp what both share.
#include "tests/tools/log_recording.hpp"

namespace chasles::testing {
namespace {

using log_recording::chasles;
using log_recording::expect_error;
using log_recording::kPandaJoints;
using log_recording::panda;
using log_recording::raw_events;
using log_recording::RawEvent;
using log_recording::Recording;
using log_recording::state_message;
using log_recording::status_message;
using log_recording::target_message;

// A CSV file as rows of cells (RFC 4180 quoting).
std::vector<std::vector<std::string>> read_csv(const std::string& text) {
  std::vector<std::vector<std::string>> rows(1);
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cell += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().push_back(cell);
      cell.clear();
    } else if (c == '\n') {
      rows.back().push_back(cell);
      cell.clear();
      rows.emplace_back();
    } else {
      cell += c;
    }
  }
  if (rows.back().empty()) rows.pop_back();
  return rows;
}

// The CSV's rows as maps from column name to cell.
std::vector<std::map<std::string, std::string>> csv_records(const std::string& path) {
  const auto rows = read_csv(read_file(path));
  std::vector<std::map<std::string, std::string>> records;
  if (rows.empty()) return records;
  for (size_t r = 1; r < rows.size(); ++r) {
    EXPECT_EQ(rows[r].size(), rows[0].size()) << "row " << r;
    std::map<std::string, std::string> record;
    for (size_t c = 0; c < rows[0].size() && c < rows[r].size(); ++c) record[rows[0][c]] = rows[r][c];
    records.push_back(std::move(record));
  }
  return records;
}

double number(const std::map<std::string, std::string>& record, const std::string& column) {
  const auto it = record.find(column);
  if (it == record.end()) {
    ADD_FAILURE() << "no column " << column;
    return NAN;
  }
  return std::strtod(it->second.c_str(), nullptr);
}

TEST(log, ExportGivesBackEveryMessageSent) {
  Recording recording("export.lcmlog");
  constexpr int kStates = 120, kStatuses = 30, kTargets = 6;
  for (int k = 0; k < kStates; ++k) {
    recording.send("CHASLES_STATE", state_message(k));
    if (k < kStatuses) recording.send("CHASLES_STATUS", status_message(k));
    if (k < kTargets) recording.send("CHASLES_TARGET", target_message(k));
  }
  recording.finish();

  // States: joint arrays by the URDF's joint names, every value exactly as sent.
  const std::string csv = temp_path("states.csv");
  RunResult r = chasles(concat({"log", "export", recording.path, "--channel", "CHASLES_STATE", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto answer = nlohmann::json::parse(r.out);
  EXPECT_EQ(answer["messages"], kStates);
  EXPECT_EQ(answer["type"], "chasles.robot_state_t");
  EXPECT_EQ(answer["columns"], 3 + 3 + 3 * 7);
  auto records = csv_records(csv);
  ASSERT_EQ(records.size(), size_t(kStates));
  double last_t = -1.0;
  for (int k = 0; k < kStates; ++k) {
    const robot_state_t sent = state_message(k);
    const auto& row = records[size_t(k)];
    EXPECT_EQ(row.at("utime"), std::to_string(sent.utime));
    EXPECT_EQ(row.at("seq"), std::to_string(k));
    EXPECT_EQ(row.at("num_joints"), "7");
    for (int j = 0; j < 7; ++j) {
      const std::string& name = kPandaJoints[size_t(j)];
      EXPECT_EQ(number(row, "position[" + name + "]"), sent.position[size_t(j)]) << "state " << k << " " << name;
      EXPECT_EQ(number(row, "velocity[" + name + "]"), sent.velocity[size_t(j)]) << "state " << k << " " << name;
      EXPECT_EQ(number(row, "effort[" + name + "]"), sent.effort[size_t(j)]) << "state " << k << " " << name;
    }
    EXPECT_GE(number(row, "log_t"), last_t);
    last_t = number(row, "log_t");
  }
  std::remove(csv.c_str());

  // Status: every field, the string with its comma and quotes intact; without a URDF the joints
  // are j0..j6.
  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_STATUS", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  records = csv_records(csv);
  ASSERT_EQ(records.size(), size_t(kStatuses));
  for (int k = 0; k < kStatuses; ++k) {
    const controller_status_t sent = status_message(k);
    const auto& row = records[size_t(k)];
    EXPECT_EQ(row.at("state"), std::to_string(int{sent.state}));
    EXPECT_EQ(row.at("message"), sent.message);
    for (int j = 0; j < 7; ++j) {
      const std::string label = "[j" + std::to_string(j) + "]";
      EXPECT_EQ(number(row, "q" + label), sent.q[size_t(j)]);
      EXPECT_EQ(number(row, "q_desired" + label), sent.q_desired[size_t(j)]);
      EXPECT_EQ(number(row, "tracking_error" + label), sent.tracking_error[size_t(j)]);
      EXPECT_EQ(number(row, "torque" + label), sent.torque[size_t(j)]);
    }
    EXPECT_EQ(number(row, "tip_position[x]"), sent.tip_position[0]);
    EXPECT_EQ(number(row, "tip_position[z]"), sent.tip_position[2]);
    EXPECT_EQ(number(row, "tip_quaternion[w]"), sent.tip_quaternion[0]);
    EXPECT_EQ(number(row, "tip_quaternion[x]"), sent.tip_quaternion[1]);
    EXPECT_EQ(number(row, "ik_iterations"), sent.ik_iterations);
    for (int j = 0; j < 7; ++j) EXPECT_EQ(number(row, "tau_ext[j" + std::to_string(j) + "]"), sent.tau_ext[size_t(j)]);
    EXPECT_EQ(number(row, "tip_wrench_ext[mx]"), sent.tip_wrench_ext[0]);
    EXPECT_EQ(number(row, "tip_wrench_ext[fz]"), sent.tip_wrench_ext[5]);
    EXPECT_EQ(row.at("contact"), sent.contact ? "1" : "0");
    EXPECT_EQ(row.at("collision"), sent.collision ? "1" : "0");
    EXPECT_EQ(number(row, "reflexes"), sent.reflexes);
    EXPECT_EQ(number(row, "ik_residual"), sent.ik_residual);
    EXPECT_EQ(row.at("ik_converged"), sent.ik_converged ? "1" : "0");
    EXPECT_EQ(number(row, "jitter_max_us"), sent.jitter_max_us);
    EXPECT_EQ(number(row, "compute_p99_us"), sent.compute_p99_us);
    EXPECT_EQ(number(row, "latency_p50_us"), sent.latency_p50_us);
    EXPECT_EQ(row.at("ticks"), std::to_string(sent.ticks));
    EXPECT_EQ(row.at("overruns"), std::to_string(sent.overruns));
    EXPECT_EQ(row.at("stale_states"), std::to_string(sent.stale_states));
    EXPECT_EQ(row.at("rejected_messages"), std::to_string(sent.rejected_messages));
    EXPECT_EQ(row.at("faults"), std::to_string(sent.faults));
  }
  std::remove(csv.c_str());

  // Targets: HOLD and CARTESIAN carry no joints, JOINT seven; the columns are the widest and the
  // cells a message does not have are empty.
  r = chasles(concat({"log", "export", recording.path, "--channel", "CHASLES_TARGET", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  records = csv_records(csv);
  ASSERT_EQ(records.size(), size_t(kTargets));
  for (int k = 0; k < kTargets; ++k) {
    const arm_target_t sent = target_message(k);
    const auto& row = records[size_t(k)];
    EXPECT_EQ(row.at("mode"), std::to_string(int{sent.mode}));
    EXPECT_EQ(number(row, "duration"), sent.duration);
    EXPECT_EQ(number(row, "tip_position[y]"), sent.tip_position[1]);
    for (int j = 0; j < 7; ++j) {
      const std::string cell = row.at("joint_position[" + kPandaJoints[size_t(j)] + "]");
      if (sent.num_joints == 0) {
        EXPECT_EQ(cell, "");
      } else {
        EXPECT_EQ(std::strtod(cell.c_str(), nullptr), sent.joint_position[size_t(j)]);
      }
    }
  }
  std::remove(csv.c_str());

  // To standard output, the CSV is the whole output.
  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_TARGET", "--out", "-"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_csv(r.out).size(), size_t(kTargets + 1));
}

// The control laws, payloads and the simulator's truth a run records export too, every field as
// sent: a Cartesian impedance with a posture, a joint impedance, a payload, two truths.
TEST(log, ExportGivesBackModesPayloadsAndTruths) {
  Recording recording("modes.lcmlog");
  control_mode_t cartesian{};
  cartesian.utime = 11;
  cartesian.law = control_mode_t::CARTESIAN_IMPEDANCE;
  cartesian.damping_ratio = 0.8;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) cartesian.cartesian_stiffness[r][c] = r == c ? 100.0 * (r + 1) : 0.5 * (r + c);
  }
  cartesian.stiffness_frame_position[2] = 0.1;
  cartesian.stiffness_frame_quaternion[0] = 1.0;
  cartesian.num_posture = 7;
  for (int i = 0; i < 7; ++i) cartesian.nullspace_posture.push_back(0.1 * i - 0.3);
  cartesian.nullspace_stiffness = 12.5;
  control_mode_t joint{};
  joint.utime = 12;
  joint.law = control_mode_t::JOINT_IMPEDANCE;
  joint.num_joints = 7;
  for (int i = 0; i < 7; ++i) joint.joint_stiffness.push_back(100.0 + i), joint.joint_damping.push_back(0.25 * i);
  joint.damping_ratio = 1.0;
  joint.stiffness_frame_quaternion[0] = 1.0;
  payload_t payload{};
  payload.utime = 13;
  payload.mass = 1.5;
  payload.centre_of_mass[0] = 0.01, payload.centre_of_mass[2] = 0.05;
  payload.inertia[0][0] = 0.002, payload.inertia[1][1] = 0.003, payload.inertia[2][2] = 0.004;
  recording.send("CHASLES_MODE", cartesian);
  recording.send("CHASLES_MODE", joint);
  recording.send("CHASLES_PAYLOAD", payload);
  for (int k = 0; k < 2; ++k) {
    sim_truth_t truth{};
    truth.utime = 20 + k;
    truth.seq = k;
    truth.num_joints = 7;
    for (int i = 0; i < 7; ++i) truth.tau_ext.push_back(0.5 * i + k);
    for (int i = 0; i < 6; ++i) truth.tip_wrench_ext[i] = i - 2.5 * k;
    truth.contact = k == 1;
    recording.send("CHASLES_TRUTH", truth);
  }
  recording.finish();

  const std::string csv = temp_path("modes.csv");
  RunResult r = chasles(concat({"log", "export", recording.path, "--channel", "CHASLES_MODE", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "chasles.control_mode_t");
  auto records = csv_records(csv);
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].at("law"), "2");
  EXPECT_EQ(number(records[0], "damping_ratio"), 0.8);
  for (int r6 = 0; r6 < 6; ++r6) {
    for (int c = 0; c < 6; ++c) {
      const std::string name = "cartesian_stiffness[" + std::to_string(r6) + "][" + std::to_string(c) + "]";
      EXPECT_EQ(number(records[0], name), cartesian.cartesian_stiffness[r6][c]) << name;
    }
  }
  EXPECT_EQ(number(records[0], "stiffness_frame_position[z]"), 0.1);
  EXPECT_EQ(number(records[0], "stiffness_frame_quaternion[w]"), 1.0);
  EXPECT_EQ(records[0].at("num_posture"), "7");
  EXPECT_EQ(number(records[0], "nullspace_stiffness"), 12.5);
  EXPECT_EQ(records[0].at("joint_stiffness[" + kPandaJoints[0] + "]"), "");  // a Cartesian law has none
  EXPECT_EQ(records[1].at("law"), "1");
  for (int j = 0; j < 7; ++j) {
    const std::string& name = kPandaJoints[size_t(j)];
    EXPECT_EQ(number(records[0], "nullspace_posture[" + name + "]"), cartesian.nullspace_posture[size_t(j)]);
    EXPECT_EQ(number(records[1], "joint_stiffness[" + name + "]"), joint.joint_stiffness[size_t(j)]);
    EXPECT_EQ(number(records[1], "joint_damping[" + name + "]"), joint.joint_damping[size_t(j)]);
  }
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_PAYLOAD", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "chasles.payload_t");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(number(records[0], "mass"), 1.5);
  EXPECT_EQ(number(records[0], "centre_of_mass[x]"), 0.01);
  EXPECT_EQ(number(records[0], "centre_of_mass[z]"), 0.05);
  EXPECT_EQ(number(records[0], "inertia[y][y]"), 0.003);
  EXPECT_EQ(number(records[0], "inertia[x][z]"), 0.0);
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_TRUTH", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "chasles.sim_truth_t");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(records[size_t(k)].at("seq"), std::to_string(k));
    EXPECT_EQ(number(records[size_t(k)], "tau_ext[j6]"), 0.5 * 6 + k);
    EXPECT_EQ(number(records[size_t(k)], "tip_wrench_ext[fz]"), 5 - 2.5 * k);
    EXPECT_EQ(records[size_t(k)].at("contact"), k == 1 ? "1" : "0");
  }
  std::remove(csv.c_str());
}

// An arm driven over Drake's protocols logs its driver's messages: each exports field for field,
// in the .lcm contract's order, with the joints named from the URDF.
TEST(log, ExportGivesBackDrakesIiwaAndPandaMessages) {
  Recording recording("drake.lcmlog");
  drake::lcmt_iiwa_status status{};
  status.utime = 5000;
  status.num_joints = 7;
  std::vector<double>* fields[] = {&status.joint_position_measured, &status.joint_velocity_estimated,
                                         &status.joint_position_commanded, &status.joint_position_ipo,
                                         &status.joint_torque_measured, &status.joint_torque_commanded,
                                         &status.joint_torque_external};
  for (size_t f = 0; f < 7; ++f) {
    for (int i = 0; i < 7; ++i) fields[f]->push_back(10.0 * double(f) + 0.25 * i);
  }
  drake::lcmt_iiwa_command command{};
  command.utime = 5000;
  command.num_joints = 0;
  command.num_torques = 7;
  for (int i = 0; i < 7; ++i) command.joint_torque.push_back(-1.5 * i);
  drake::lcmt_panda_command panda_command{};
  panda_command.utime = 7000;
  panda_command.num_joint_torque = 7;
  for (int i = 0; i < 7; ++i) panda_command.joint_torque.push_back(0.5 * i);
  panda_command.control_mode_expected = drake::lcmt_panda_status::CONTROL_MODE_TORQUE;
  recording.send("IIWA_STATUS", status);
  recording.send("IIWA_COMMAND", command);
  recording.send("PANDA_COMMAND", panda_command);
  recording.finish();

  const std::string csv = temp_path("drake.csv");
  RunResult r = chasles(concat({"log", "export", recording.path, "--channel", "IIWA_STATUS", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "drake.lcmt_iiwa_status");
  auto records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].at("utime"), "5000");
  const char* names[] = {"joint_position_measured", "joint_velocity_estimated", "joint_position_commanded",
                         "joint_position_ipo", "joint_torque_measured", "joint_torque_commanded",
                         "joint_torque_external"};
  for (size_t f = 0; f < 7; ++f) {
    for (int i = 0; i < 7; ++i) {
      const std::string column = std::string(names[f]) + "[" + kPandaJoints[size_t(i)] + "]";
      EXPECT_EQ(number(records[0], column), 10.0 * double(f) + 0.25 * i) << column;
    }
  }
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "IIWA_COMMAND", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "drake.lcmt_iiwa_command");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].at("num_joints"), "0");
  EXPECT_EQ(records[0].at("num_torques"), "7");
  EXPECT_EQ(records[0].at("joint_position[j0]"), "");  // torque-only: no positions
  EXPECT_EQ(number(records[0], "joint_torque[j6]"), -9.0);
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "PANDA_COMMAND", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "drake.lcmt_panda_command");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].at("num_joint_torque"), "7");
  EXPECT_EQ(number(records[0], "joint_torque[j3]"), 1.5);
  EXPECT_EQ(records[0].at("control_mode_expected"), "4");
  std::remove(csv.c_str());
}

TEST(log, ExportRefusesWhatItCannotDo) {
  Recording recording("refusals.lcmlog");
  for (int k = 0; k < 3; ++k) recording.send("CHASLES_STATE", state_message(k));
  recording.send_bytes("OTHER", {1, 2, 3, 4, 5, 6, 7, 8, 9});
  recording.finish();
  const std::string csv = temp_path("refused.csv");
  const auto refused = [&](const std::vector<std::string>& args, const std::string& needle) {
    const RunResult r = chasles(args);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
    EXPECT_FALSE(std::ifstream(csv).good()) << "a refused export wrote " << csv;
  };
  refused({"log", "export", recording.path, "--channel", "CHASLES_STATUS", "--out", csv},
          "no messages on CHASLES_STATUS (channels in the log: CHASLES_STATE 3, OTHER 1, WARMUP");
  refused({"log", "export", recording.path, "--channel", "OTHER", "--out", csv}, "are not of a type chasles reads");
  refused(concat({"log", "export", recording.path, "--channel", "CHASLES_STATE", "--out", csv},
                 {"--urdf", data_path("ur5.urdf"), "--tip", "tool0"}),
          "carry 7 joints; the URDF's chain has 6");
  refused({"log", "export", temp_path("no_such.lcmlog"), "--channel", "CHASLES_STATE", "--out", csv},
          "cannot open the log");
  const TempFile empty("empty.lcmlog", "");
  refused({"log", "export", empty.path, "--channel", "CHASLES_STATE", "--out", csv},
          "no messages on CHASLES_STATE (channels in the log: none)");
  const RunResult usage = chasles({"log", "export", recording.path, "--out", csv});
  EXPECT_EQ(usage.exit_code, 2);
  EXPECT_NE(usage.err.find("--channel is required"), std::string::npos) << usage.err;
  EXPECT_NE(usage.err.find("chasles log export --help"), std::string::npos) << usage.err;
}

// What export makes of a damaged copy of a log: exit status, stderr, and the seq of every row.
struct DamagedExport {
  RunResult result;
  std::vector<int64_t> seqs;
};

DamagedExport export_damaged(const std::string& bytes, const std::string& name) {
  const TempFile log(name, bytes);
  const std::string csv = temp_path(name + ".csv");
  DamagedExport out;
  out.result = chasles({"log", "export", log.path, "--channel", "CHASLES_STATE", "--out", csv});
  for (const auto& row : csv_records(csv)) out.seqs.push_back(std::stoll(row.at("seq")));
  std::remove(csv.c_str());
  return out;
}

std::vector<int64_t> iota(int64_t from, int64_t to) {
  std::vector<int64_t> v;
  for (int64_t k = from; k < to; ++k) v.push_back(k);
  return v;
}

TEST(log, DamagedLogsExportWhatIsReadableAndNameTheByte) {
  Recording recording("damaged.lcmlog");
  constexpr int kStates = 40;
  for (int k = 0; k < kStates; ++k) recording.send("CHASLES_STATE", state_message(k));
  const std::string log = recording.finish();
  std::vector<RawEvent> states;
  for (const RawEvent& e : raw_events(log)) {
    if (e.channel == "CHASLES_STATE") states.push_back(e);
  }
  ASSERT_EQ(states.size(), size_t(kStates));
  ASSERT_EQ(states.back().offset + states.back().size, log.size()) << "the state messages should end the log";

  // Cut in the middle of state 30's message: states 0..29 come out, the error names where 30 starts.
  const RawEvent& s30 = states[30];
  DamagedExport d = export_damaged(log.substr(0, s30.offset + s30.size / 2), "cut_data");
  expect_error(d.result, "byte " + std::to_string(s30.offset) + ": event #");
  expect_error(d.result, "is cut short: it needs " + std::to_string(s30.size) + " bytes and the file ends " +
                             std::to_string(s30.size / 2) + " bytes after its start");
  expect_error(d.result, "exported the 30 readable messages on CHASLES_STATE");
  EXPECT_EQ(d.seqs, iota(0, 30));

  // Cut inside an event header.
  d = export_damaged(log.substr(0, s30.offset + 10), "cut_header");
  expect_error(d.result, "byte " + std::to_string(s30.offset) + ": the last 10 bytes are too few for an event header");
  EXPECT_EQ(d.seqs, iota(0, 30));

  // State 12's sync word overwritten: it is lost, the reader finds state 13 and goes on.
  std::string damaged = log;
  damaged[states[12].offset + 1] = 'X';
  d = export_damaged(damaged, "bad_sync");
  expect_error(d.result, "byte " + std::to_string(states[12].offset) + ": no event starts here (0xED58DA01 where");
  expect_error(d.result, "skipped " + std::to_string(states[12].size) + " bytes to the next event, at byte " +
                             std::to_string(states[13].offset));
  std::vector<int64_t> expected = iota(0, 12), rest = iota(13, kStates);
  expected.insert(expected.end(), rest.begin(), rest.end());
  EXPECT_EQ(d.seqs, expected);

  // A forged data length of 2 GB in state 20's header: too long for the file; state 21 is found.
  damaged = log;
  for (int i = 0; i < 4; ++i) damaged[states[20].offset + 24 + size_t(i)] = "\x7f\xff\xff\xf0"[i];
  d = export_damaged(damaged, "forged_length");
  expect_error(d.result, "byte " + std::to_string(states[20].offset) + ": event #");
  expect_error(d.result, "is cut short: it needs 2147483");
  expected = iota(0, 20);
  rest = iota(21, kStates);
  expected.insert(expected.end(), rest.begin(), rest.end());
  EXPECT_EQ(d.seqs, expected);

  // Well framed, but state 5's num_joints says -3 and state 6's 1000: skipped, each named.
  damaged = log;
  const auto set_count = [&](const RawEvent& e, uint32_t count) {
    const size_t at = e.offset + 28 + e.channel.size() + 8 + 8 + 8;  // fingerprint, utime, seq
    for (int i = 0; i < 4; ++i) damaged[at + size_t(i)] = char((count >> (24 - 8 * i)) & 0xff);
  };
  set_count(states[5], uint32_t(-3));
  set_count(states[6], 1000);
  d = export_damaged(damaged, "bad_counts");
  expect_error(d.result, "byte " + std::to_string(states[5].offset) + ": event #");
  expect_error(d.result, "is a message num_joints -3 in a message of 196 bytes; skipped");
  expect_error(d.result, "byte " + std::to_string(states[6].offset) + ": event #");
  expect_error(d.result, "num_joints 1000");
  EXPECT_EQ(d.seqs.size(), size_t(kStates - 2));

  // Random damage, seeded: never a crash or a hang, always exit 0 or 1, never more rows than sent.
  std::mt19937 rng(20240611);
  for (int trial = 0; trial < 60; ++trial) {
    damaged = log;
    const int flips = 1 + int(rng() % 8);
    for (int f = 0; f < flips; ++f) damaged[rng() % damaged.size()] = char(rng() & 0xff);
    if (trial % 3 == 0) damaged.resize(rng() % damaged.size());
    d = export_damaged(damaged, "random_" + std::to_string(trial));
    EXPECT_TRUE(d.result.exit_code == 0 || d.result.exit_code == 1) << "trial " << trial << ": " << d.result.err;
    EXPECT_LE(d.seqs.size(), size_t(kStates)) << "trial " << trial;
    if (d.result.exit_code == 1) {
      EXPECT_NE(d.result.err.find("byte "), std::string::npos) << d.result.err;
    }
  }
}

}  // namespace
}  // namespace chasles::testing
