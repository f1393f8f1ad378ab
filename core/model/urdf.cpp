#include "core/model/urdf.hpp"

#include <console_bridge/console.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "core/lie/se3.hpp"
#include "core/lie/so3.hpp"
#include "core/model/inertia.hpp"

namespace chasles {
namespace {

[[noreturn]] void fail(const std::string& source, const std::string& what) { throw ModelError(source + ": " + what); }

std::string quoted_list(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "'" : ", '") + name + "'";
  return out;
}

// urdfdom reports problems through console_bridge and sometimes goes on regardless (a link whose
// <inertial> does not parse loses it silently). Every error it logs fails the load.
class UrdfdomErrors : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) messages.push_back(text);
  }
  std::vector<std::string> messages;
};

urdf::ModelInterfaceSharedPtr parse_with_urdfdom(const std::string& xml, const std::string& source) {
  static std::mutex mutex;  // console_bridge's handler is global
  std::lock_guard<std::mutex> lock(mutex);
  UrdfdomErrors errors;
  console_bridge::useOutputHandler(&errors);
  urdf::ModelInterfaceSharedPtr parsed;
  try {
    parsed = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    errors.messages.push_back(e.what());
  }
  console_bridge::restorePreviousOutputHandler();
  if (!parsed || !errors.messages.empty()) {
    std::string what;
    for (const auto& m : errors.messages) what += (what.empty() ? "" : "; ") + m;
    fail(source, what.empty() ? "not a valid URDF" : what);
  }
  return parsed;
}

// urdfdom reports a cycle as "no root link" and a link with two parents as "two root links";
// this pass names the joints and links involved before urdfdom sees the file.
void check_tree_structure(const std::string& xml, const std::string& source) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    fail(source, std::string("malformed XML at line ") + std::to_string(doc.ErrorLineNum()) + ": " + doc.ErrorName());
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) fail(source, "no <robot> element");

  std::set<std::string> links;
  for (auto* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const char* name = e->Attribute("name");
    if (!name) fail(source, "a <link> has no name (line " + std::to_string(e->GetLineNum()) + ")");
    if (!links.insert(name).second) fail(source, std::string("link '") + name + "' is defined twice");
  }
  std::map<std::string, std::pair<std::string, std::string>> parent_of;  // child → (joint, parent)
  for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const char* name = e->Attribute("name");
    if (!name) fail(source, "a <joint> has no name (line " + std::to_string(e->GetLineNum()) + ")");
    const std::string where = std::string("joint '") + name + "'";
    auto* p = e->FirstChildElement("parent");
    auto* c = e->FirstChildElement("child");
    const char* parent = p ? p->Attribute("link") : nullptr;
    const char* child = c ? c->Attribute("link") : nullptr;
    if (!parent || !child) fail(source, where + " needs <parent link=...> and <child link=...>");
    if (!links.count(parent)) fail(source, where + " names parent link '" + parent + "', which does not exist");
    if (!links.count(child)) fail(source, where + " names child link '" + child + "', which does not exist");
    auto [it, inserted] = parent_of.emplace(child, std::make_pair(std::string(name), std::string(parent)));
    if (!inserted) {
      fail(source, "link '" + std::string(child) + "' has two parent joints, '" + it->second.first + "' and '" + name +
                       "': a URDF must be a tree");
    }
  }
  for (const auto& start : parent_of) {
    std::set<std::string> seen{start.first};
    std::vector<std::string> joints;
    for (auto it = parent_of.find(start.first); it != parent_of.end(); it = parent_of.find(it->second.second)) {
      joints.push_back(it->second.first);
      if (!seen.insert(it->second.second).second) {
        fail(source, "the joints " + quoted_list(joints) + " form a cycle: a URDF must be a tree");
      }
    }
  }
}

// One <drake:rotor_inertia value=.../> or <drake:gear_ratio value=.../> of an actuator: absent →
// `absent`; present, a finite number (≥ 0 where `non_negative`), else the load fails naming the joint.
double drake_value(const tinyxml2::XMLElement& actuator, const char* tag, double absent, bool non_negative,
                   const std::string& joint, const std::string& transmission, const std::string& source) {
  const tinyxml2::XMLElement* e = actuator.FirstChildElement(tag);
  if (!e) return absent;
  const std::string where = "joint '" + joint + "': <" + tag + "> of transmission '" + transmission + "' (line " +
                            std::to_string(e->GetLineNum()) + ")";
  const char* text = e->Attribute("value");
  if (!text) fail(source, where + " has no value attribute");
  // strtod and not tinyxml2's QueryDoubleAttribute, which takes "1.5kg" for 1.5.
  char* end = nullptr;
  const double value = std::strtod(text, &end);
  while (end != text && std::isspace(static_cast<unsigned char>(*end))) ++end;
  if (end == text || *end != '\0') fail(source, where + ": value '" + text + "' is not a number");
  if (!std::isfinite(value)) fail(source, where + ": value '" + text + "' is not finite");
  if (non_negative && value < 0.0) {
    fail(source, where + ": value " + text + " is negative; a rotor inertia is kg*m^2 (kg for a prismatic joint), >= 0");
  }
  return value;
}

// Drake's URDF extension for reflected rotor inertia, which urdfdom drops: in a <transmission>
// naming a joint of the chain, an <actuator> with <drake:rotor_inertia value=I/> and
// <drake:gear_ratio value=ρ/> (absent: 0 and 1, Drake's defaults) gives that joint the armature
// I ρ² (Drake's JointActuator::reflected_inertia). ρ may be negative (a gear pair that turns the
// motor the other way); only ρ² enters. Transmissions of joints off the chain are ignored.
std::vector<double> read_armature(const std::string& xml, const std::vector<Joint>& joints, const std::string& source) {
  std::vector<double> armature(joints.size(), 0.0);
  std::vector<std::string> given_by(joints.size());  // the transmission that set each joint's, for a duplicate
  tinyxml2::XMLDocument doc;
  doc.Parse(xml.c_str(), xml.size());  // check_tree_structure has parsed it already
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  for (auto* t = robot->FirstChildElement("transmission"); t; t = t->NextSiblingElement("transmission")) {
    const char* name_attribute = t->Attribute("name");
    const std::string name = name_attribute ? name_attribute : "(unnamed, line " + std::to_string(t->GetLineNum()) + ")";
    const tinyxml2::XMLElement* joint = t->FirstChildElement("joint");
    const char* joint_name = joint ? joint->Attribute("name") : nullptr;
    if (!joint_name) continue;
    size_t i = 0;
    while (i < joints.size() && joints[i].name != joint_name) ++i;
    if (i == joints.size()) continue;  // off the chain, or fixed: locked, so its rotor never turns
    for (auto* a = t->FirstChildElement("actuator"); a; a = a->NextSiblingElement("actuator")) {
      if (!a->FirstChildElement("drake:rotor_inertia") && !a->FirstChildElement("drake:gear_ratio")) continue;
      const double inertia = drake_value(*a, "drake:rotor_inertia", 0.0, true, joint_name, name, source);
      const double ratio = drake_value(*a, "drake:gear_ratio", 1.0, false, joint_name, name, source);
      if (!given_by[i].empty()) {
        fail(source, "joint '" + std::string(joint_name) + "': transmissions '" + given_by[i] + "' and '" + name +
                         "' both give it a rotor (drake:rotor_inertia, drake:gear_ratio): one per joint");
      }
      given_by[i] = name;
      armature[i] = inertia * (ratio * ratio);
    }
  }
  return armature;
}

// Drake's URDF extension for acceleration limits, which urdfdom drops: <limit
// drake:acceleration="A"/> on a joint of the chain, A > 0 in rad/s² (m/s²).
void read_acceleration_limits(const std::string& xml, std::vector<Joint>& joints, const std::string& source) {
  tinyxml2::XMLDocument doc;
  doc.Parse(xml.c_str(), xml.size());  // check_tree_structure has parsed it already
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  for (auto* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const char* name = j->Attribute("name");
    const tinyxml2::XMLElement* limit = j->FirstChildElement("limit");
    const char* text = limit ? limit->Attribute("drake:acceleration") : nullptr;
    if (!name || !text) continue;
    auto joint = std::find_if(joints.begin(), joints.end(), [&](const Joint& c) { return c.name == name; });
    if (joint == joints.end()) continue;  // off the chain
    char* end = nullptr;
    const double value = std::strtod(text, &end);
    while (end != text && std::isspace(static_cast<unsigned char>(*end))) ++end;
    if (end == text || *end != '\0' || !std::isfinite(value) || value <= 0.0) {
      fail(source, "joint '" + std::string(name) + "': <limit drake:acceleration=\"" + text + "\"> (line " +
                       std::to_string(limit->GetLineNum()) + ") is not a positive number (rad/s^2, m/s^2)");
    }
    joint->limits.acceleration = value;
  }
}

Transform to_transform(const urdf::Pose& pose) {
  const Eigen::Quaterniond q(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z);
  return make_transform(q.normalized().toRotationMatrix(), Vector3d(pose.position.x, pose.position.y, pose.position.z));
}

bool is_finite(const urdf::Pose& pose) {
  return std::isfinite(pose.position.x) && std::isfinite(pose.position.y) && std::isfinite(pose.position.z) &&
         std::isfinite(pose.rotation.x) && std::isfinite(pose.rotation.y) && std::isfinite(pose.rotation.z) &&
         std::isfinite(pose.rotation.w);
}

// A link's <inertial>: mass, rotational inertia about the centre of mass c in the link frame
// (turned by the <inertial> rpy), and c. Non-finite values and negative masses are malformed
// whatever link they are on; whether the inertia is physical is judged by the caller.
struct LinkInertial {
  double mass;
  Matrix3d I_c;
  Transform T_link_com;
};

LinkInertial read_inertial(const urdf::Inertial& in, const std::string& link, const std::string& source) {
  const std::string where = "link '" + link + "': ";
  const double values[] = {in.mass, in.ixx, in.ixy, in.ixz, in.iyy, in.iyz, in.izz};
  for (double v : values) {
    if (!std::isfinite(v)) fail(source, where + "<inertial> holds a non-finite number");
  }
  if (!is_finite(in.origin)) fail(source, where + "<inertial> origin is not finite");
  if (in.mass < 0.0) fail(source, where + "mass " + std::to_string(in.mass) + " is negative");
  LinkInertial out{in.mass, Matrix3d(), to_transform(in.origin)};
  Matrix3d I_com;
  I_com << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  const Matrix3d& R = out.T_link_com.linear();
  out.I_c = R * I_com * R.transpose();
  return out;
}

// Spatial inertia about the link frame, (ω, v) order: the rotational inertia at the centre of
// mass moved to the link origin (MR eq. 8.32).
Matrix6d link_spatial_inertia(const LinkInertial& in) {
  const Matrix3d C = hat3(in.T_link_com.translation());
  Matrix6d G;
  G << in.I_c + in.mass * C * C.transpose(), in.mass * C,  //
      in.mass * C.transpose(), in.mass * Matrix3d::Identity();
  return G;
}

std::string read_file(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail(path, std::string("cannot open URDF file: ") + std::strerror(errno));
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) fail(path, "cannot read URDF file");
  return text.str();
}

}  // namespace

RobotModel load_urdf_file(const std::string& path, const UrdfOptions& options) {
  return load_urdf_string(read_file(path), options, path);
}

RobotModel load_urdf_string(const std::string& xml, const UrdfOptions& options, const std::string& source) {
  check_tree_structure(xml, source);
  const urdf::ModelInterfaceSharedPtr urdf = parse_with_urdfdom(xml, source);
  const urdf::LinkConstSharedPtr root = urdf->getRoot();

  // The tip: the one asked for, or the single leaf.
  std::string tip = options.tip_link;
  if (tip.empty()) {
    std::vector<std::string> leaves;
    for (const auto& [name, link] : urdf->links_) {
      if (link->child_joints.empty()) leaves.push_back(name);
    }
    if (leaves.size() != 1) {
      throw TipNotChosenError(source + ": the tree has " + std::to_string(leaves.size()) + " leaves (" +
                              quoted_list(leaves) + "): name the tip link");
    }
    tip = leaves.front();
  }
  if (!urdf->getLink(tip)) fail(source, "unknown tip link '" + tip + "'");

  // The path root → tip, and which of its joints move.
  std::vector<urdf::JointConstSharedPtr> path;
  std::vector<std::string> path_links{tip};
  for (auto link = urdf->getLink(tip); link->parent_joint; link = urdf->getLink(link->parent_joint->parent_link_name)) {
    path.insert(path.begin(), link->parent_joint);
    path_links.insert(path_links.begin(), link->parent_joint->parent_link_name);
  }
  ChainDescription d;
  d.name = urdf->getName();
  d.source = source;
  d.base_link = root->name;
  d.tip_link = tip;
  d.gravity = options.gravity;
  std::map<std::string, int> chain_joint;  // joint name → body index it starts (1..n)
  for (const auto& j : path) {
    const std::string where = "joint '" + j->name + "' on the chain is ";
    switch (j->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS:
      case urdf::Joint::PRISMATIC: break;
      case urdf::Joint::FIXED: continue;
      case urdf::Joint::FLOATING: fail(source, where + "floating: chasles models fixed-base serial chains");
      case urdf::Joint::PLANAR: fail(source, where + "planar: chasles models 1-dof joints only");
      default: fail(source, where + "of unknown type");
    }
    if (j->mimic)
      fail(source, where + "a mimic of '" + j->mimic->joint_name + "': mimic joints are not supported on the chain");
    Joint joint;
    joint.name = j->name;
    joint.type = j->type == urdf::Joint::REVOLUTE     ? JointType::Revolute
                 : j->type == urdf::Joint::CONTINUOUS ? JointType::Continuous
                                                      : JointType::Prismatic;
    const Vector3d axis(j->axis.x, j->axis.y, j->axis.z);
    if (!axis.allFinite()) fail(source, "joint '" + j->name + "': axis is not finite");
    if (axis.norm() < 1e-9) fail(source, "joint '" + j->name + "': axis is zero");
    joint.axis = axis.normalized();
    const double inf = std::numeric_limits<double>::infinity();
    if (joint.type == JointType::Continuous) {
      joint.limits = {-kPi, kPi, inf, inf, inf};
    } else if (!j->limits) {
      fail(source, "joint '" + j->name + "': no <limit>");
    } else {
      joint.limits.lower = j->limits->lower;
      joint.limits.upper = j->limits->upper;
    }
    if (j->limits) {
      // URDF requires both attributes, so exporters that do not know a limit write 0; a joint
      // that may not move or push is no joint at all, so 0 reads as "no limit given".
      joint.limits.velocity = j->limits->velocity == 0.0 ? inf : j->limits->velocity;
      joint.limits.effort = j->limits->effort == 0.0 ? inf : j->limits->effort;
      const double l[] = {j->limits->lower, j->limits->upper, j->limits->velocity, j->limits->effort};
      for (double v : l) {
        if (!std::isfinite(v)) fail(source, "joint '" + j->name + "': <limit> holds a non-finite number");
      }
      if (joint.limits.lower > joint.limits.upper) {
        fail(source, "joint '" + j->name + "': lower limit " + std::to_string(joint.limits.lower) +
                         " is above upper limit " + std::to_string(joint.limits.upper));
      }
    }
    d.joints.push_back(joint);
    chain_joint[j->name] = static_cast<int>(d.joints.size());
  }
  if (d.joints.empty()) fail(source, "no movable joint between '" + root->name + "' and '" + tip + "'");
  d.armature = read_armature(xml, d.joints, source);
  read_acceleration_limits(xml, d.joints, source);

  // Place every link on a body: a chain joint starts a new body; every other joint is locked at
  // 0, so its child rides on its parent's body.
  struct Placement {
    int body;
    Transform T_body_link;
  };
  std::map<std::string, Placement> placement{{root->name, {0, Transform::Identity()}}};
  d.inertia.assign(d.joints.size(), Matrix6d::Zero());
  // Links whose own inertia is not physical; what the dynamics sees is the body they ride on,
  // judged once every link is on it.
  struct OddLink {
    int body;
    std::string link, problem;
  };
  std::vector<OddLink> odd_links;
  std::vector<std::vector<std::string>> body_links(d.joints.size() + 1);
  std::vector<urdf::LinkConstSharedPtr> stack{root};
  while (!stack.empty()) {
    const urdf::LinkConstSharedPtr link = stack.back();
    stack.pop_back();
    const Placement here = placement.at(link->name);
    body_links[static_cast<size_t>(here.body)].push_back(link->name);
    if (link->inertial) {
      const LinkInertial inertial = read_inertial(*link->inertial, link->name, source);
      const InertiaCheck check = check_inertia(inertial.mass, inertial.I_c);
      const std::string where = "link '" + link->name + "': ";
      if (here.body == 0) {
        if (!check.physical()) {
          d.warnings.push_back(where + check.problem + "; it is fixed to the base '" + root->name +
                               "', so its inertia never enters the dynamics");
        }
      } else {
        if (!check.physical()) odd_links.push_back({here.body, link->name, check.problem});
        if (check.point_mass) {
          std::ostringstream mass;
          mass << inertial.mass;
          d.warnings.push_back(where + "a point mass (" + mass.str() +
                               " kg, no rotational inertia about its centre of mass)");
        }
        // G_body = [Ad_{T_link,body}]ᵀ G_link [Ad_{T_link,body}] (MR eq. 8.42).
        const Matrix6d Ad = adjoint(inverse(here.T_body_link));
        d.inertia[static_cast<size_t>(here.body - 1)] += Ad.transpose() * link_spatial_inertia(inertial) * Ad;
      }
    }
    for (const auto& j : link->child_joints) {
      if (!is_finite(j->parent_to_joint_origin_transform)) {
        fail(source, "joint '" + j->name + "': origin is not finite");
      }
      const Transform T_parent_joint = here.T_body_link * to_transform(j->parent_to_joint_origin_transform);
      const auto chain = chain_joint.find(j->name);
      if (chain != chain_joint.end()) {
        d.joints[static_cast<size_t>(chain->second - 1)].T_parent_joint = T_parent_joint;
        placement[j->child_link_name] = {chain->second, Transform::Identity()};
      } else {
        placement[j->child_link_name] = {here.body, T_parent_joint};
      }
      stack.push_back(urdf->getLink(j->child_link_name));
    }
  }
  // Each moving body as a whole must be physical: the sum of physical parts always is, so a body
  // fails only through a part that is not, and then the message names both.
  for (size_t b = 1; b < body_links.size(); ++b) {
    const SpatialInertia G = SpatialInertia::from_matrix(d.inertia[b - 1]);
    const InertiaCheck check = check_inertia(G.mass, inertia_about_centre_of_mass(G.mass, G.h, G.I));
    const std::string body = "the body moved by joint '" + d.joints[b - 1].name + "' (links " +
                             quoted_list(body_links[b]) + ")";
    if (!check.physical()) {
      std::string parts;
      for (const OddLink& odd : odd_links) {
        if (odd.body == static_cast<int>(b)) parts += "; its link '" + odd.link + "': " + odd.problem;
      }
      fail(source, body + " has an inertia that is not physical: " + check.problem + parts);
    }
    for (const OddLink& odd : odd_links) {
      if (odd.body != static_cast<int>(b)) continue;
      d.warnings.push_back("link '" + odd.link + "': " + odd.problem + "; " + body +
                           " is physical as a whole, so the model loads");
    }
  }
  for (const auto& name : path_links) {
    const Placement& p = placement.at(name);
    d.links.push_back({name, p.body, p.T_body_link});
  }
  d.T_last_tip = placement.at(tip).T_body_link;
  return RobotModel(std::move(d));
}

JointFriction joint_friction_from_urdf(const std::string& xml, const RobotModel& model) {
  const std::string& source = model.description().source;
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS || doc.FirstChildElement("robot") == nullptr) {
    throw ModelError(source + ": malformed XML at line " + std::to_string(doc.ErrorLineNum()));
  }
  JointFriction friction{Eigen::VectorXd::Zero(model.dof()), Eigen::VectorXd::Zero(model.dof())};
  for (auto* e = doc.FirstChildElement("robot")->FirstChildElement("joint"); e != nullptr;
       e = e->NextSiblingElement("joint")) {
    const char* name = e->Attribute("name");
    const int i = name != nullptr ? model.joint_index(name) : -1;
    const tinyxml2::XMLElement* dynamics = e->FirstChildElement("dynamics");
    if (i < 0 || dynamics == nullptr) continue;
    for (const auto& [attribute, value] :
         {std::pair{"damping", &friction.viscous[i]}, std::pair{"friction", &friction.coulomb[i]}}) {
      const char* text = dynamics->Attribute(attribute);
      if (text == nullptr) continue;
      char* end = nullptr;
      *value = std::strtod(text, &end);
      if (end == text || *end != '\0' || !std::isfinite(*value) || *value < 0.0) {
        throw ModelError(source + ": joint '" + name + "': <dynamics " + attribute + "=\"" + text +
                         "\"> is not a finite number >= 0");
      }
    }
  }
  return friction;
}

JointFriction joint_friction_from_urdf_file(const std::string& path, const RobotModel& model) {
  return joint_friction_from_urdf(read_file(path), model);
}

}  // namespace chasles
