// What the extension's two translation units share: the Python Model and the registration of
// the solvers' bindings (solvers.cpp), which link Ceres, apart from the model's (core.cpp).
#pragma once

#include <memory>

#include "arrays.hpp"
#include "core/model/model.hpp"

namespace chasles::python {

/// chasles.Model: an immutable RobotModel, shared with the solvers and observers made from it
/// (they outlive the Python object if they must), and the Data single calls write into. Single
/// calls hold the GIL, so one Data serves every thread; a batch releases the GIL and makes its own.
struct Model {
  explicit Model(RobotModel model) : robot(std::make_shared<const RobotModel>(std::move(model))), data(*robot) {}

  std::shared_ptr<const RobotModel> robot;
  Data data;
};

/// chasles.IkOptions, IkResult, IkSolver; Dataset, CalibrationOptions, calibrate and the rest of
/// the calibration.
void bind_solvers(nb::module_& m);

/// chasles.read_scene_file and decode_scene (scene.cpp): scenes read by the controller's readers.
void bind_scene(nb::module_& m);

}  // namespace chasles::python
