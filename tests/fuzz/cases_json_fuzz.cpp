// The JSON case readers of `chasles eval` and `chasles ik` on arbitrary text, against the UR5:
// parse errors and bad cases are InputError; accepted cases hold one finite value per joint, and
// IK targets are finite rigid transforms.
#include <cstdint>
#include <string>

#include "core/ik/ik.hpp"
#include "core/model/urdf.hpp"
#include "tools/cli/cases.hpp"
#include "fuzz/check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace chasles;
  static const RobotModel model = load_urdf_file(CHASLES_TEST_DATA "/ur5.urdf", {"tool0"});
  const std::string text(reinterpret_cast<const char*>(data), size);
  cli::Json document;
  try {
    document = cli::parse_json_text(text, "fuzz.json", "cases file");
  } catch (const cli::InputError&) {
    return 0;
  }
  try {
    for (const cli::EvalCase& c : cli::parse_eval_cases(document, model, "fuzz.json")) {
      FUZZ_CHECK(c.q.size() == model.dof() && c.q.allFinite());
      if (c.has_dynamics) {
        FUZZ_CHECK(c.qd.size() == model.dof() && c.qd.allFinite());
        FUZZ_CHECK(c.qdd.size() == model.dof() && c.qdd.allFinite());
      }
    }
  } catch (const cli::InputError&) {
  }
  try {
    for (const cli::IkTarget& t : cli::parse_ik_targets(document, model, "fuzz.json")) {
      check_rigid_transform(t.T_sd);  // throws ArgumentError: not caught, a crash
      FUZZ_CHECK(t.q_seed.size() == model.dof() && t.q_seed.allFinite());
    }
  } catch (const cli::InputError&) {
  }
  return 0;
}
