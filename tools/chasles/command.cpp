#include "command.hpp"

#include <cmath>
#include <vector>

#include "chasles/core/model/urdf.hpp"

namespace chasles::cli {

void add_model_options(CLI::App& command, ModelOptions& options) {
  command.add_option("--urdf", options.urdf, "Robot description (URDF file)")->required()->type_name("FILE");
  command.add_option("--tip", options.tip, "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
}

RobotModel load_model(const ModelOptions& options) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = options.tip;
  return load_urdf_file(options.urdf, urdf_options);
}

}  // namespace chasles::cli

namespace chasles::cli {

Eigen::VectorXd parse_list(const std::string& text, Eigen::Index n, const std::string& option) {
  std::vector<double> values;
  size_t start = 0;
  while (true) {
    const size_t end = text.find(',', start);
    const std::string item = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    const size_t index = values.size();
    size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos) {
      throw InputError(option + ": entry " + std::to_string(index) + " ('" + item + "') is not a number");
    }
    if (!std::isfinite(value)) {
      throw InputError(option + ": entry " + std::to_string(index) + " ('" + item + "') is not finite");
    }
    values.push_back(value);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  if (static_cast<Eigen::Index>(values.size()) != n) {
    throw InputError(option + " has " + std::to_string(values.size()) + " entries, expected " + std::to_string(n) +
                     " (one per joint, comma-separated)");
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), n);
}

}  // namespace chasles::cli
