// Starting LCM for a subcommand, with a failure reported as one line.
#pragma once

#include <lcm/lcm.h>

#include <string>

namespace chasles::cli {

/// lcm_create(url) ("" for $LCM_DEFAULT_URL, else LCM's default). LCM explains a failure to start
/// over a dozen lines of stderr; they are kept back and the first becomes part of the InputError
/// thrown, with a hint about multicast routes for udpm URLs. The caller lcm_destroy()s the result.
lcm_t* start_lcm(const std::string& url);

}  // namespace chasles::cli
