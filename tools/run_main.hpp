// One front door for the tools' main(): each tool parses its command line itself (CLI11's usage
// errors, exit 2, are worded per tool) and hands the work to run_main, which maps whatever escapes
// it to one line "<tool>: <message>" on stderr and exit status 1, the same way in every tool.
#pragma once

#include <exception>
#include <functional>
#include <new>
#include <string>

#include "core/error.hpp"
#include "core/model/urdf.hpp"
#include "tools/error_line.hpp"

namespace chasles::tools {

/// Runs `body` and returns its exit status. An exception that escapes it is reported by
/// fail(tool, ...) with status 1:
///   TipNotChosenError   its message and " with --tip" (every tool names the tip with --tip)
///   chasles::Error      its message, which names the input at fault (a URDF, a file, a dataset, a
///                       value): ModelError, CalibrationError, ArgumentError, cli::InputError, ...
///   std::bad_alloc      "out of memory"
///   anything else       "internal error: " and its message: a bug, not bad input
inline int run_main(const char* tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const TipNotChosenError& e) {
    return fail(tool, std::string(e.what()) + " with --tip", 1);
  } catch (const Error& e) {
    return fail(tool, e.what(), 1);
  } catch (const std::bad_alloc&) {
    return fail(tool, "out of memory", 1);
  } catch (const std::exception& e) {
    return fail(tool, std::string("internal error: ") + e.what(), 1);
  }
}

}  // namespace chasles::tools
