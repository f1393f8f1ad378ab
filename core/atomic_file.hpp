// Files written whole or not at all.
#pragma once

#include <string>

namespace chasles {

/// Writes `content` to `path` through a temporary file beside it (mkstemp), flushed to the disk,
/// then renamed over it: a reader sees the old file or the new one, never half of one, and a
/// failure leaves the old one as it was. The file gets a plain open's mode (0666 less the umask).
/// Throws Error naming the path and the system's reason.
void write_file_atomically(const std::string& path, const std::string& content);

}  // namespace chasles
