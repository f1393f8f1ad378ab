#include "core/calibration/dataset.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "core/lie/so3.hpp"

namespace chasles {

namespace {

const char* const kPoseColumns[] = {"x", "y", "z", "qw", "qx", "qy", "qz"};

std::string trim(const std::string& s) {
  const size_t first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  const size_t last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

[[noreturn]] void fail(const std::string& source, int line, const std::string& what) {
  throw CalibrationError(source + ":" + std::to_string(line) + ": " + what);
}

std::string joint_list(const RobotModel& model) {
  std::string out;
  for (const Joint& joint : model.joints()) out += (out.empty() ? "" : ", ") + joint.name;
  return out;
}

}  // namespace

std::string shortest_number(double x) {
  if (x == 0.0) return "0";  // also turns -0 into 0
  char buffer[32];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, x);
    if (std::strtod(buffer, nullptr) == x) break;
  }
  return buffer;
}

Dataset parse_dataset(const std::string& text, const RobotModel& model, const std::string& source) {
  const int n = model.dof();
  std::istringstream in(text);
  std::string raw;
  int line = 0;
  // column index of each joint (chain order), then x y z qw qx qy qz (−1: absent)
  std::vector<int> joint_column(static_cast<size_t>(n), -1);
  int pose_column[7] = {-1, -1, -1, -1, -1, -1, -1};
  std::vector<std::string> header;
  Dataset dataset;
  while (std::getline(in, raw)) {
    ++line;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    const std::string content = trim(raw);
    if (content.empty() || content[0] == '#') continue;
    const std::vector<std::string> fields = split_fields(content);
    if (header.empty()) {
      header = fields;
      for (size_t c = 0; c < fields.size(); ++c) {
        const std::string& name = fields[c];
        const int column = static_cast<int>(c);
        int* slot = nullptr;
        for (int k = 0; k < 7; ++k) {
          if (name == kPoseColumns[k]) slot = &pose_column[k];
        }
        const int joint = model.joint_index(name);
        if (joint >= 0) slot = &joint_column[static_cast<size_t>(joint)];
        if (slot == nullptr) {
          char* end = nullptr;
          std::strtod(name.c_str(), &end);
          const bool number = !name.empty() && end == name.c_str() + name.size();
          fail(source, line,
               "unknown column '" + name + "': expected the chain's joints (" + joint_list(model) +
                   "), x, y, z and optionally qw, qx, qy, qz" + (number ? " (is the header line missing?)" : ""));
        }
        if (*slot >= 0) fail(source, line, "column '" + name + "' appears twice");
        *slot = column;
      }
      for (int i = 0; i < n; ++i) {
        if (joint_column[static_cast<size_t>(i)] < 0) {
          fail(source, line, "no column for joint '" + model.joint(i).name + "' (every joint of the chain needs one)");
        }
      }
      for (int k = 0; k < 3; ++k) {
        if (pose_column[k] < 0) fail(source, line, std::string("no column '") + kPoseColumns[k] + "' (marker position, m)");
      }
      int quaternion = 0;
      for (int k = 3; k < 7; ++k) quaternion += pose_column[k] >= 0 ? 1 : 0;
      if (quaternion != 0 && quaternion != 4) {
        fail(source, line, "the orientation needs all four columns qw, qx, qy, qz, or none of them");
      }
      dataset.has_orientation = quaternion == 4;
      continue;
    }
    if (fields.size() != header.size()) {
      fail(source, line, std::to_string(fields.size()) + " fields, expected " + std::to_string(header.size()) +
                             " (one per header column)");
    }
    std::vector<double> values(fields.size());
    for (size_t c = 0; c < fields.size(); ++c) {
      const std::string& field = fields[c];
      char* end = nullptr;
      errno = 0;
      const double value = field.empty() ? 0.0 : std::strtod(field.c_str(), &end);
      if (field.empty() || end != field.c_str() + field.size() || !std::isfinite(value)) {
        fail(source, line, "column '" + header[c] + "': '" + field + "' is not a finite number");
      }
      values[c] = value;
    }
    Measurement m;
    m.line = line;
    m.q.resize(n);
    for (int i = 0; i < n; ++i) m.q[i] = values[static_cast<size_t>(joint_column[static_cast<size_t>(i)])];
    for (int k = 0; k < 3; ++k) m.p_tracker_marker[k] = values[static_cast<size_t>(pose_column[k])];
    if (dataset.has_orientation) {
      Eigen::Quaterniond q(values[static_cast<size_t>(pose_column[3])], values[static_cast<size_t>(pose_column[4])],
                           values[static_cast<size_t>(pose_column[5])], values[static_cast<size_t>(pose_column[6])]);
      const double norm = q.norm();
      if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
        fail(source, line, "the quaternion (qw, qx, qy, qz) has norm " + shortest_number(norm) + ", expected 1");
      }
      m.has_orientation = true;
      m.R_tracker_marker = q.normalized().toRotationMatrix();
    }
    dataset.rows.push_back(std::move(m));
  }
  if (header.empty()) fail(source, std::max(line, 1), "no header line (joint names, x, y, z[, qw, qx, qy, qz])");
  if (dataset.rows.empty()) fail(source, line, "no data rows after the header");
  return dataset;
}

Dataset read_dataset(const std::string& path, const RobotModel& model) {
  std::ostringstream text;
  if (path == "-") {
    text << std::cin.rdbuf();
    return parse_dataset(text.str(), model, "<stdin>");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) throw CalibrationError(path + ": cannot open the dataset: " + std::strerror(errno));
  text << file.rdbuf();
  if (file.bad()) throw CalibrationError(path + ": cannot read the dataset");
  return parse_dataset(text.str(), model, path);
}

std::string format_dataset(const RobotModel& model, const std::vector<Measurement>& rows, bool with_orientation) {
  std::string out;
  for (const Joint& joint : model.joints()) out += joint.name + ",";
  out += with_orientation ? "x,y,z,qw,qx,qy,qz\n" : "x,y,z\n";
  for (const Measurement& m : rows) {
    for (int i = 0; i < model.dof(); ++i) out += shortest_number(m.q[i]) + ",";
    out += shortest_number(m.p_tracker_marker.x()) + "," + shortest_number(m.p_tracker_marker.y()) + "," +
           shortest_number(m.p_tracker_marker.z());
    if (with_orientation) {
      if (!m.has_orientation) throw ArgumentError("format_dataset: a row has no orientation");
      Eigen::Quaterniond q(m.R_tracker_marker);
      if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // one of the two signs, w ≥ 0
      out += "," + shortest_number(q.w()) + "," + shortest_number(q.x()) + "," + shortest_number(q.y()) + "," +
             shortest_number(q.z());
    }
    out += "\n";
  }
  return out;
}

}  // namespace chasles
