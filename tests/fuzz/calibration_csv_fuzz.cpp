// The calibration dataset reader on arbitrary text, against the UR5: CalibrationError naming the
// line, or rows with one finite value per joint, a finite position, and a rotation matrix where
// the file has orientation.
#include <cmath>
#include <cstdint>
#include <string>

#include "core/calibration/dataset.hpp"
#include "core/model/urdf.hpp"
#include "fuzz/check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace chasles;
  static const RobotModel model = load_urdf_file(CHASLES_TEST_DATA "/ur5.urdf", {"tool0"});
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const Dataset dataset = parse_dataset(text, model, "fuzz.csv");
    FUZZ_CHECK(!dataset.rows.empty());
    for (const Measurement& row : dataset.rows) {
      FUZZ_CHECK(row.q.size() == model.dof() && row.q.allFinite());
      FUZZ_CHECK(row.p_tracker_marker.allFinite());
      FUZZ_CHECK(row.has_orientation == dataset.has_orientation);
      if (row.has_orientation) {
        const Matrix3d& R = row.R_tracker_marker;
        FUZZ_CHECK((R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9);
        FUZZ_CHECK(std::abs(R.determinant() - 1.0) < 1e-9);
      }
      FUZZ_CHECK(row.line > 1);
    }
  } catch (const CalibrationError&) {
  }
  return 0;
}
