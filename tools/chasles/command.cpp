#include "command.hpp"

#include <cctype>
#include <stdexcept>
#include <vector>

#include "core/model/urdf.hpp"
#include "core/number_list.hpp"
#include "tools/error_line.hpp"

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
    values = parse_number_list(text, option);
  } catch (const ArgumentError& e) {
    throw InputError(e.what());
  }
  if (static_cast<Eigen::Index>(values.size()) != n) {
    throw InputError(option + " has " + std::to_string(values.size()) + " entries, expected " + std::to_string(n) +
                     " (one per joint, comma-separated)");
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), n);
}

void add_wire_options(CLI::App& command, WireOptions& wire, const std::string& what, const std::string& channel) {
  command.add_option("--channel-prefix", wire.prefix, "The " + what + " goes out on PREFIX " + channel)
      ->check(
          [](const std::string& prefix) {
            // The controller subscribes by name: only characters that match themselves in a pattern.
            for (const char c : prefix) {
              if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '/') {
                return std::string("letters, digits, '_', '-' and '/' only");
              }
            }
            return std::string();
          },
          "")
      ->type_name("PREFIX")
      ->capture_default_str();
  command.add_option("--lcm-url", wire.lcm_url, "LCM provider URL (default: $LCM_DEFAULT_URL, else LCM's default)")
      ->type_name("URL");
}

}  // namespace chasles::cli
