// The smallest useful downstream program: load a URDF, print the tip pose at q = 0, and read a
// joint state from its wire bytes with the checked decoder.
#include <chasles/core/kinematics/kinematics.hpp>
#include <chasles/core/model/urdf.hpp>
#include <chasles/lcmtypes/checked.hpp>
#include <iostream>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  chasles::UrdfOptions options;
  options.tip_link = "tool0";
  const chasles::RobotModel model = chasles::load_urdf_file(argv[1], options);
  chasles::Data data(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.dof());
  const chasles::Transform& T_sb = chasles::forward_kinematics(model, data, q);
  std::cout << model.name() << " dof " << model.dof() << "\n" << T_sb.matrix() << "\n";

  chasles::robot_state_t sent{};
  sent.num_joints = model.dof();
  sent.position.assign(size_t(model.dof()), 0.5);
  sent.velocity.assign(size_t(model.dof()), 0.0);
  sent.effort.assign(size_t(model.dof()), 0.0);
  std::vector<uint8_t> bytes(size_t(sent.getEncodedSize()));
  sent.encode(bytes.data(), 0, int(bytes.size()));
  chasles::robot_state_t received;
  const std::string why = chasles::messages::decode_checked(bytes.data(), bytes.size(), received, model.dof(),
                                                            chasles::messages::Finite::Required);
  const bool as_sent = why.empty() && received.position == sent.position;
  const std::string short_why = chasles::messages::decode_checked(bytes.data(), bytes.size() - 1, received);
  std::cout << "state: " << (why.empty() ? "decoded" : why) << "; one byte short: " << short_why << "\n";
  const bool kinematics_ok = (T_sb.matrix() - model.home_tip().matrix()).norm() < 1e-12;
  return kinematics_ok && as_sent && !short_why.empty() ? 0 : 1;
}
