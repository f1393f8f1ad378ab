#include "tools/cli/state_log.hpp"

#include "tools/cli/json_io.hpp"
#include "tools/cli/lcm_log.hpp"
#include "tools/cli/messages.hpp"

namespace chasles::cli {

std::string channel_list(const std::map<std::string, int64_t>& counts) {
  std::string text;
  for (const auto& [channel, count] : counts) {
    text += (text.empty() ? "" : ", ") + channel + " " + std::to_string(count);
  }
  return text.empty() ? "none" : text;
}

StateLog read_states(const std::string& path, const std::string& channel) {
  StateLog log;
  std::map<std::string, int64_t> counts;
  LogReader reader(path);
  LogEvent event;
  robot_state_t state;
  int64_t last_seq = 0;
  std::string other_type;
  while (reader.next(event)) {
    ++counts[event.channel];
    if (event.channel != channel) continue;
    const std::string why = decode_checked(event.data.data(), event.data.size(), state);
    if (!why.empty()) {
      const MessageType type = message_type(event.data.data(), event.data.size());
      if (type != MessageType::State && type != MessageType::Unknown && other_type.empty()) {
        other_type = type_name(type);
      }
      log.problems.push_back("byte " + std::to_string(event.offset) + ": event #" + std::to_string(event.number) +
                             " on " + channel + " is " + (why.rfind("not a", 0) == 0 ? "" : "a message ") + why);
      continue;
    }
    if (log.utime.empty()) log.joints = state.num_joints;
    if (state.num_joints != log.joints) {
      log.problems.push_back("byte " + std::to_string(event.offset) + ": event #" + std::to_string(event.number) +
                             " on " + channel + " is a state of " + std::to_string(state.num_joints) +
                             " joints, where the first had " + std::to_string(log.joints));
      continue;
    }
    // The same seq is the same state sent again; a smaller one is a sender restarted, whose
    // states are new (their times say where they belong).
    if (!log.utime.empty() && state.seq == last_seq) {
      ++log.repeated;
      continue;
    }
    last_seq = state.seq;
    log.utime.push_back(state.utime);
    log.position.insert(log.position.end(), state.position.begin(), state.position.end());
    log.velocity.insert(log.velocity.end(), state.velocity.begin(), state.velocity.end());
    log.effort.insert(log.effort.end(), state.effort.begin(), state.effort.end());
  }
  log.problems.insert(log.problems.begin(), reader.problems().begin(), reader.problems().end());
  if (counts.count(channel) == 0) {
    throw InputError(path + ": no messages on " + channel + " (channels in the log: " + channel_list(counts) + ")");
  }
  if (log.utime.empty()) {
    throw InputError(path + ": no chasles.robot_state_t on " + channel +
                     (other_type.empty() ? " (" + log.problems.front() + ")" : ": its messages are " + other_type));
  }
  return log;
}

}  // namespace chasles::cli
