// The smallest useful downstream program: load a URDF and print the tip pose at q = 0.
#include <chasles/core/kinematics/kinematics.hpp>
#include <chasles/core/model/urdf.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  chasles::UrdfOptions options;
  options.tip_link = "tool0";
  const chasles::RobotModel model = chasles::load_urdf_file(argv[1], options);
  chasles::Data data(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  const chasles::Transform& T_sb = chasles::forward_kinematics(model, data, q);
  std::cout << model.name() << " dof " << model.dof() << "\n" << T_sb.matrix() << "\n";
  return (T_sb.matrix() - model.home_tip().matrix()).norm() < 1e-12 ? 0 : 1;
}
