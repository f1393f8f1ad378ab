// JSON conversion shared by the chasles subcommands: Eigen values to JSON lists, JSON input to
// checked Eigen vectors, reading a JSON file with an error that says where it went wrong.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/error.hpp"
#include "core/lie/types.hpp"

namespace chasles::cli {

/// Keys keep the order they were added in, so output reads in the documented order.
using Json = nlohmann::ordered_json;

/// Bad input (a file, its JSON, a value in it): a chasles::Error, which the tools' run_main
/// prints as "chasles: <what>" with exit status 1; what() names the file and the place in it.
class InputError : public Error {
 public:
  using Error::Error;
};

/// A double, or null when it is not finite (JSON has no ∞ or NaN).
Json number(double x);

/// A vector as a list of numbers.
Json vector_json(const Eigen::Ref<const Eigen::VectorXd>& v);

/// A matrix as a list of rows (4×4 transforms, 6×n Jacobians).
Json rows_json(const Eigen::Ref<const Eigen::MatrixXd>& m);

/// A matrix as a list of its columns (screw axes: n 6-vectors).
Json columns_json(const Eigen::Ref<const Eigen::MatrixXd>& m);

/// A rigid transform as its 4×4 matrix, a list of rows.
Json transform_json(const Transform& T);

/// Reads and parses a JSON file ("-" reads standard input). `what` describes the file in error
/// messages ("cases file"). Throws InputError naming the file, and for malformed JSON the line,
/// column and byte where parsing stopped.
Json read_json_file(const std::string& path, const std::string& what);

/// The same for text already read; `name` is the file's name in messages.
Json parse_json_text(const std::string& text, const std::string& name, const std::string& what);

/// The "cases" list of a cases or targets document read from `path` ("-": standard input, named
/// "<stdin>"); throws InputError naming the file when the top level is not an object with one.
const Json& cases_list(const Json& document, const std::string& path);

/// The member `key` of `object`; throws InputError "<where> has no "<key>"" when `object` is not
/// an object or lacks the key.
const Json& member(const Json& object, const std::string& key, const std::string& where);

/// A list of exactly n finite numbers. `where` names the value in messages ("f.json: cases[3].q");
/// `meaning` explains n ("one per joint"). Throws InputError otherwise.
Eigen::VectorXd parse_vector(const Json& value, Eigen::Index n, const std::string& where,
                             const std::string& meaning = "");

/// JSON's name for the type of a value, for messages ("a string", "an object").
std::string describe_type(const Json& value);

/// The document as text: compact, or indented by 2 with `pretty`. Doubles are written in
/// shortest round-trip form (they parse back to the same bits); invalid UTF-8 in strings (a
/// link name, say) is replaced rather than thrown.
std::string dump(const Json& document, bool pretty);

}  // namespace chasles::cli
