#include "tools/cli/json_io.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace chasles::cli {

Json number(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

Json vector_json(const Eigen::Ref<const Eigen::VectorXd>& v) {
  Json out = Json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) out.push_back(number(v(i)));
  return out;
}

Json rows_json(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  Json out = Json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) out.push_back(vector_json(m.row(r).transpose()));
  return out;
}

Json columns_json(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  Json out = Json::array();
  for (Eigen::Index c = 0; c < m.cols(); ++c) out.push_back(vector_json(m.col(c)));
  return out;
}

Json transform_json(const Transform& T) { return rows_json(T.matrix()); }

namespace {

std::string read_text(const std::string& path, const std::string& what) {
  std::ostringstream text;
  if (path == "-") {
    text << std::cin.rdbuf();
    if (std::cin.bad()) throw InputError("<stdin>: cannot read the " + what);
    return text.str();
  }
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": cannot read the " + what + ": is a directory");
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path + ": cannot open the " + what + ": " + std::strerror(errno));
  text << file.rdbuf();
  if (file.bad()) throw InputError(path + ": cannot read the " + what);
  return text.str();
}

// nlohmann's messages start with a tag, "[json.exception.parse_error.101] parse error at line L,
// column C: ..."; keep the part after it.
std::string without_tag(std::string message) {
  const auto tag_end = message.find("] ");
  if (message.rfind("[json.exception.", 0) == 0 && tag_end != std::string::npos) message.erase(0, tag_end + 2);
  return message;
}

}  // namespace

const Json& cases_list(const Json& document, const std::string& path) {
  const std::string file = path == "-" ? "<stdin>" : path;
  if (!document.is_object())
    throw InputError(file + ": the top level is " + describe_type(document) +
                     ", expected an object with a \"cases\" list");
  const auto cases = document.find("cases");
  if (cases == document.end()) throw InputError(file + ": no \"cases\" list at the top level");
  if (!cases->is_array()) throw InputError(file + ": \"cases\" is " + describe_type(*cases) + ", expected a list");
  return *cases;
}

Json read_json_file(const std::string& path, const std::string& what) {
  return parse_json_text(read_text(path, what), path == "-" ? "<stdin>" : path, what);
}

Json parse_json_text(const std::string& text, const std::string& name, const std::string& what) {
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    throw InputError(name + ": the " + what + " is not valid JSON (byte " + std::to_string(e.byte) +
                     "): " + without_tag(e.what()));
  } catch (const Json::exception& e) {  // out_of_range.406: a number beyond double, as 1e999
    throw InputError(name + ": the " + what + " cannot be read as JSON: " + without_tag(e.what()));
  }
}

const Json& member(const Json& object, const std::string& key, const std::string& where) {
  if (!object.is_object()) throw InputError(where + " is " + describe_type(object) + ", expected an object");
  const auto it = object.find(key);
  if (it == object.end()) throw InputError(where + " has no \"" + key + "\"");
  return *it;
}

Eigen::VectorXd parse_vector(const Json& value, Eigen::Index n, const std::string& where, const std::string& meaning) {
  const std::string expected = std::to_string(n) + " numbers" + (meaning.empty() ? "" : " (" + meaning + ")");
  if (!value.is_array()) throw InputError(where + " is " + describe_type(value) + ", expected a list of " + expected);
  if (static_cast<Eigen::Index>(value.size()) != n) {
    throw InputError(where + " has " + std::to_string(value.size()) + " entries, expected " + expected);
  }
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Json& x = value[static_cast<size_t>(i)];
    const std::string at = where + "[" + std::to_string(i) + "]";
    if (!x.is_number()) throw InputError(at + " is " + describe_type(x) + ", expected a number");
    v(i) = x.get<double>();
    // The parser turns 1e999 into ∞; JSON itself cannot spell ∞ or NaN.
    if (!std::isfinite(v(i))) throw InputError(at + " is not a finite number");
  }
  return v;
}

std::string describe_type(const Json& value) {
  switch (value.type()) {
    case Json::value_t::null: return "null";
    case Json::value_t::object: return "an object";
    case Json::value_t::array: return "a list";
    case Json::value_t::string: return "a string";
    case Json::value_t::boolean: return "a boolean";
    case Json::value_t::number_integer:
    case Json::value_t::number_unsigned:
    case Json::value_t::number_float: return "a number";
    case Json::value_t::binary: return "binary data";
    case Json::value_t::discarded: break;
  }
  return "not a value";
}

std::string dump(const Json& document, bool pretty) {
  return document.dump(pretty ? 2 : -1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace chasles::cli
