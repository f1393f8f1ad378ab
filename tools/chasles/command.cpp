#include "command.hpp"

#include <stdexcept>
#include <vector>

#include "chasles/core/model/urdf.hpp"
#include "chasles/tools/error_line.hpp"
#include "chasles/tools/number_list.hpp"

namespace chasles::cli {

void add_model_options(CLI::App& command, ModelOptions& options) {
  command.add_option("--urdf", options.urdf, "Robot description (URDF file)")->required()->type_name("FILE");
  command.add_option("--tip", options.tip, "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
}

RobotModel load_model(const ModelOptions& options) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = options.tip;
  RobotModel model = load_urdf_file(options.urdf, urdf_options);
  tools::warn("chasles", options.urdf, model.warnings());
  return model;
}

}  // namespace chasles::cli

namespace chasles::cli {

Eigen::VectorXd parse_list(const std::string& text, Eigen::Index n, const std::string& option) {
  std::vector<double> values;
  try {
    values = tools::parse_number_list(text, option);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  if (static_cast<Eigen::Index>(values.size()) != n) {
    throw InputError(option + " has " + std::to_string(values.size()) + " entries, expected " + std::to_string(n) +
                     " (one per joint, comma-separated)");
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), n);
}

}  // namespace chasles::cli
