// Calibration datasets as CSV: a header, then one row per measured configuration.
//
//   <joint>,...,x,y,z[,qw,qx,qy,qz]
//
// One column per joint of the chain, named exactly as the URDF joint (any order); x, y, z the
// marker position in the tracker frame (m); optionally qw, qx, qy, qz its orientation (a unit
// quaternion, w first, as the tracker reports it). Blank lines and lines starting with '#' are
// skipped. Every error names the file and line.
#pragma once

#include <string>
#include <vector>

#include "core/calibration/calibration.hpp"

namespace chasles {

struct Dataset {
  bool has_orientation = false;  ///< the file has the quaternion columns
  std::vector<Measurement> rows;  ///< Measurement::line is the file's line (1-based)
};

/// Parses dataset text for `model`'s chain; `source` names it in messages. Throws
/// CalibrationError "<source>:<line>: ..." for an unknown or missing column, a row with the wrong
/// number of fields, a value that is not a finite number, a quaternion far from unit norm (more
/// than 1e-3; nearer ones are normalised), or a file without rows.
Dataset parse_dataset(const std::string& text, const RobotModel& model, const std::string& source);

/// Reads and parses a dataset file ("-": standard input).
Dataset read_dataset(const std::string& path, const RobotModel& model);

/// The rows as dataset text, joints in chain order, numbers in shortest round-trip form; with
/// orientation when `with_orientation` (every row must have one).
std::string format_dataset(const RobotModel& model, const std::vector<Measurement>& rows, bool with_orientation);

/// The shortest decimal form of x that reads back to the same double ("0.1", "1e-05").
std::string shortest_number(double x);

}  // namespace chasles
