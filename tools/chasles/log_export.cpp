// chasles log export: one channel of an LCM log as CSV, one column per field and joint arrays by
// joint name, written whole or not at all (AtomicFile); the undecodable messages and the framing
// damage are collected in file order and end the command once the readable rows are out. Apart from
// the plots (log_plot.cpp), with which it shares the log reader and nothing else.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>

#include "tools/chasles/log_command.hpp"
#include "tools/cli/lcm_log.hpp"
#include "tools/cli/messages.hpp"
#include "tools/cli/state_log.hpp"

namespace chasles::cli {
namespace {

std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

// A file written under a temporary name beside its destination and renamed over it once
// complete, so a reader never sees half of it and a failed run leaves the old one.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path)
      : path_(std::move(path)), temporary_(path_ + ".tmp-" + std::to_string(::getpid())) {
    file_.open(temporary_, std::ios::binary | std::ios::trunc);
    if (!file_) throw InputError(path_ + ": cannot write (" + std::strerror(errno) + ")");
  }
  ~AtomicFile() {
    if (!committed_) std::remove(temporary_.c_str());
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ostream& stream() { return file_; }

  void commit() {
    file_.close();
    if (!file_ || std::rename(temporary_.c_str(), path_.c_str()) != 0) {
      throw InputError(path_ + ": cannot write (" + std::strerror(errno) + ")");
    }
    committed_ = true;
  }

 private:
  std::string path_, temporary_;
  std::ofstream file_;
  bool committed_ = false;
};

}  // namespace

Json run_log_export(const LogOptions& options) {
  const std::optional<JointInfo> joints = load_joints(options);

  // First pass: the channel's type and its widest joint array, so every row has the same columns
  // (a HOLD target carries no joints, a JOINT target all of them).
  std::map<std::string, int64_t> counts;
  MessageType type = MessageType::Unknown;
  int width = 0;
  int64_t first_utime = 0;
  bool any_event = false;
  {
    LogReader reader(options.log);
    LogEvent event;
    while (reader.next(event)) {
      if (!any_event) first_utime = event.utime;
      any_event = true;
      ++counts[event.channel];
      if (event.channel != options.channel) continue;
      const MessageType this_type = message_type(event.data.data(), event.data.size());
      if (type == MessageType::Unknown) type = this_type;
      if (this_type != type) continue;
      width = std::max(width, joint_count(type, event.data.data(), event.data.size()));
    }
    if (counts.count(options.channel) == 0) {
      if (!reader.problems().empty()) fail_damaged(options.log, reader.problems(), "nothing on " + options.channel);
      throw InputError(options.log + ": no messages on " + options.channel + " (channels in the log: " +
                       channel_list(counts) + ")");
    }
  }
  if (type == MessageType::Unknown) {
    throw InputError(options.log + ": the messages on " + options.channel +
                     " are not of a type chasles reads (its own: robot_state_t, joint_torque_command_t, "
                     "arm_target_t, controller_status_t, control_mode_t, payload_t, sim_truth_t, "
                     "joint_setpoint_t, jog_command_t, tip_setpoint_t, contact_estimate_t; Drake's lcmt_iiwa_status, "
                     "lcmt_iiwa_command, lcmt_panda_status, lcmt_panda_command)");
  }
  const std::vector<std::string> labels =
      labels_for(joints, width, "the " + type_name(type) + " messages on " + options.channel);

  // Second pass: the rows.
  LogReader reader(options.log);
  std::vector<std::string> problems;
  std::unique_ptr<AtomicFile> file;
  std::ostream* out = &std::cout;
  if (options.out != "-") {
    file = std::make_unique<AtomicFile>(options.out);
    out = &file->stream();
  }
  out->precision(17);
  LogEvent event;
  Cells cells;
  std::vector<std::string> header;
  int64_t rows = 0;
  while (reader.next(event)) {
    if (event.channel != options.channel) continue;
    const std::string why = message_cells(type, event.data.data(), event.data.size(), labels, cells);
    if (!why.empty()) {
      problems.push_back("byte " + std::to_string(event.offset) + ": event #" + std::to_string(event.number) + " on " +
                         options.channel + " is " + (why.rfind("not a", 0) == 0 ? "" : "a message ") + why +
                         "; skipped");
      continue;
    }
    if (header.empty()) {
      header = cells.names;
      *out << "log_t,log_utime,log_event";
      for (const std::string& name : header) *out << ',' << csv_cell(name);
      *out << '\n';
    }
    *out << number_text(double(event.utime - first_utime) * 1e-6) << ',' << event.utime << ',' << event.number;
    for (const std::string& value : cells.values) *out << ',' << csv_cell(value);
    *out << '\n';
    ++rows;
  }
  out->flush();
  if (!*out) throw InputError((options.out == "-" ? std::string("standard output") : options.out) + ": write failed");
  if (file) file->commit();

  // The framing damage and the undecodable messages, in file order.
  std::vector<std::string> all = reader.problems();
  all.insert(all.end(), problems.begin(), problems.end());
  std::sort(all.begin(), all.end(), [](const std::string& a, const std::string& b) {
    return std::stoull(a.substr(5)) < std::stoull(b.substr(5));  // "byte N: ..."
  });
  if (!all.empty()) {
    fail_damaged(options.log, all,
                 "exported the " + std::to_string(rows) + " readable messages on " + options.channel + " to " +
                     (options.out == "-" ? "standard output" : options.out));
  }
  if (options.out == "-") return Json();  // the CSV was the output
  Json answer;
  answer["log"] = options.log;
  answer["channel"] = options.channel;
  answer["type"] = type_name(type);
  answer["messages"] = rows;
  answer["columns"] = 3 + header.size();
  answer["out"] = options.out;
  return answer;
}

}  // namespace chasles::cli
