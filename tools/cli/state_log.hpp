// The arm's measured states from an LCM log: every chasles.robot_state_t on one channel, in the
// order the logger wrote them, decoded by the type's checked decoder (lcmtypes/checked.hpp) as
// `chasles log export` decodes them. What a fit from a log (chasles_calibrate dynamics) reads.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace chasles::cli {

struct StateLog {
  int joints = 0;                     ///< num_joints of the first state
  std::vector<int64_t> utime;         ///< µs, the sender's sample times
  std::vector<double> position;       ///< joints per state, state after state
  std::vector<double> velocity;
  std::vector<double> effort;
  int64_t repeated = 0;               ///< states sent again (the last one's seq), left out
  std::vector<std::string> problems;  ///< damage and undecodable messages, each "byte N: ...", left out
};

/// Reads the states on `channel`. Throws InputError when the log cannot be read, has no message
/// on the channel (naming the channels it has), or its messages there are of another type.
StateLog read_states(const std::string& path, const std::string& channel);

/// "CHASLES_STATE 1200, CHASLES_COMMAND 1200": a log's channels and how many messages each, or
/// "none".
std::string channel_list(const std::map<std::string, int64_t>& counts);

}  // namespace chasles::cli
