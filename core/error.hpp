// The exceptions chasles's libraries throw, under one base, as libfranka has franka::Exception:
// a caller catches chasles::Error, or one kind of it. Every what() names the input at fault (a
// file, a joint, a link, a field) and never a command-line flag: the libraries know no tool.
#pragma once

#include <stdexcept>
#include <string>

namespace chasles {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An argument a function cannot take: a vector of the wrong size, a non-finite value, a pose
/// that is not a rigid transform, a setting out of its range.
class ArgumentError : public Error {
 public:
  using Error::Error;
};

/// Dynamics this model cannot give at this state: a mass matrix that is singular.
class DynamicsError : public Error {
 public:
  using Error::Error;
};

/// `text` without trailing line breaks and with inner ones turned into spaces: a message (from
/// urdfdom, Ceres, CLI11, ..., some of which span lines) as the one line a program's error is
/// printed as, so that a script reading stderr gets exactly one.
inline std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

}  // namespace chasles
