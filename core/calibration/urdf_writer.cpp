#include "core/calibration/urdf_writer.hpp"

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <vector>

#include "core/calibration/dataset.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"

namespace chasles {

namespace {

std::string triple(const Vector3d& v) {
  return shortest_number(v.x()) + " " + shortest_number(v.y()) + " " + shortest_number(v.z());
}

/// XML comments may not contain "--".
std::string comment_safe(std::string text) {
  for (size_t at = text.find("--"); at != std::string::npos; at = text.find("--", at)) text.replace(at, 2, "- ");
  return text;
}

void set_origin(tinyxml2::XMLElement* origin, const Transform& T) {
  origin->SetAttribute("xyz", triple(T.translation()).c_str());
  origin->SetAttribute("rpy", triple(rpy_from_rotation(T.linear())).c_str());
}

/// The element as compact XML, for a comment that keeps it.
std::string element_text(const tinyxml2::XMLElement* element) {
  tinyxml2::XMLPrinter printer(nullptr, true);
  element->Accept(&printer);
  return printer.CStr();
}

/// A comment just before `element` in its parent.
void comment_before(tinyxml2::XMLElement* element, const std::string& text) {
  tinyxml2::XMLComment* note = element->GetDocument()->NewComment(comment_safe(" " + text + " ").c_str());
  tinyxml2::XMLNode* parent = element->Parent();
  if (element->PreviousSibling() != nullptr) {
    parent->InsertAfterChild(element->PreviousSibling(), note);
  } else {
    parent->InsertFirstChild(note);
  }
}

/// `parent`'s child `name` (made when there is none), with a comment before it saying why it was
/// replaced and what it was.
tinyxml2::XMLElement* replaced_child(tinyxml2::XMLElement* parent, const char* name, const std::string& why) {
  tinyxml2::XMLElement* child = parent->FirstChildElement(name);
  if (child == nullptr) {
    child = parent->InsertNewChildElement(name);
    comment_before(child, why + "; the " + parent->Name() + " had no <" + name + ">");
  } else {
    comment_before(child, why + "; was " + element_text(child));
  }
  return child;
}

tinyxml2::XMLElement* child_element(tinyxml2::XMLElement* parent, const char* name) {
  tinyxml2::XMLElement* child = parent->FirstChildElement(name);
  return child != nullptr ? child : parent->InsertNewChildElement(name);
}

/// The links riding on the body that starts at `link` and carrying mass: its subtree, up to the
/// next movable chain joint.
std::vector<std::string> riders(const std::string& link, const std::multimap<std::string, tinyxml2::XMLElement*>& children,
                                const std::map<std::string, tinyxml2::XMLElement*>& links,
                                const std::map<std::string, int>& chain_joints) {
  std::vector<std::string> found;
  const auto [first, last] = children.equal_range(link);
  for (auto it = first; it != last; ++it) {
    const tinyxml2::XMLElement* joint = it->second;
    if (chain_joints.count(joint->Attribute("name"))) continue;
    const tinyxml2::XMLElement* child = joint->FirstChildElement("child");
    const char* name = child != nullptr ? child->Attribute("link") : nullptr;
    if (name == nullptr) continue;
    const auto element = links.find(name);
    const tinyxml2::XMLElement* inertial =
        element != links.end() ? element->second->FirstChildElement("inertial") : nullptr;
    const tinyxml2::XMLElement* mass = inertial != nullptr ? inertial->FirstChildElement("mass") : nullptr;
    if (mass != nullptr && mass->DoubleAttribute("value") > 0.0) found.push_back(name);
    for (std::string& more : riders(name, children, links, chain_joints)) found.push_back(std::move(more));
  }
  return found;
}

// The document's <robot>, parsed into `doc`; CalibrationError naming `source` when there is none.
tinyxml2::XMLElement* parsed_robot(tinyxml2::XMLDocument& doc, const std::string& xml, const std::string& source) {
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    throw CalibrationError(source + ": malformed XML at line " + std::to_string(doc.ErrorLineNum()) + ": " +
                           doc.ErrorName());
  }
  tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) throw CalibrationError(source + ": no <robot> element");
  return robot;
}

}  // namespace

Matrix3d rotation_from_rpy(const Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy[2], Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy[1], Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy[0], Vector3d::UnitX()))
      .toRotationMatrix();
}

Vector3d rpy_from_rotation(const Matrix3d& R) {
  // One angle at a time, each from entries that stay O(1): roll from the last row; then
  // R Rx(roll)ᵀ = Rz(yaw) Ry(pitch) gives yaw from its middle column; Rz(yaw)ᵀ R Rx(roll)ᵀ = Ry(pitch)
  // gives pitch. Near gimbal lock roll is ill-determined, but whatever value it takes the next two
  // steps absorb, so R is reproduced to round-off (the textbook atan2 triple loses ~ε/cos(pitch)).
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const Matrix3d R1 = R * Eigen::AngleAxisd(-roll, Vector3d::UnitX()).toRotationMatrix();
  const double yaw = std::atan2(-R1(0, 1), R1(1, 1));
  const Matrix3d R2 = Eigen::AngleAxisd(-yaw, Vector3d::UnitZ()).toRotationMatrix() * R1;
  const double pitch = std::atan2(R2(0, 2), R2(0, 0));
  return Vector3d(roll, pitch, yaw);
}

std::string corrected_urdf(const std::string& original_xml, const RobotModel& nominal,
                           const KinematicCorrections& corrections, const CorrectedUrdfOptions& options) {
  const std::string& source = nominal.description().source;
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLElement* robot = parsed_robot(doc, original_xml, source);
  std::map<std::string, tinyxml2::XMLElement*> joints, links;
  for (auto* e = robot->FirstChildElement("joint"); e != nullptr; e = e->NextSiblingElement("joint")) {
    if (const char* name = e->Attribute("name")) joints[name] = e;
  }
  for (auto* e = robot->FirstChildElement("link"); e != nullptr; e = e->NextSiblingElement("link")) {
    if (const char* name = e->Attribute("name")) links[name] = e;
  }
  if (links.count(options.marker_link)) {
    throw CalibrationError(source + ": a link named '" + options.marker_link +
                           "' exists already (calibrating a corrected URDF? make the flange the chain's tip, or "
                           "name the marker link otherwise)");
  }
  if (joints.count(options.marker_joint)) {
    throw CalibrationError(source + ": a joint named '" + options.marker_joint + "' exists already");
  }
  std::map<std::string, const ChainLink*> chain_links;
  for (const ChainLink& link : nominal.links()) chain_links[link.name] = &link;
  const RobotModel corrected_chain = corrected_model(nominal, corrections);

  for (int i = 0; i < nominal.dof(); ++i) {
    const Joint& joint = nominal.joint(i);
    const Vector6d& xi = corrections.origin[static_cast<size_t>(i)];
    const double offset = corrections.offset[i];
    if (xi.isZero(0.0) && offset == 0.0) continue;  // untouched joints stay byte for byte
    const auto found = joints.find(joint.name);
    if (found == joints.end()) throw CalibrationError(source + ": no joint '" + joint.name + "' in the XML");
    tinyxml2::XMLElement* element = found->second;
    const tinyxml2::XMLElement* parent = element->FirstChildElement("parent");
    const char* parent_link = parent != nullptr ? parent->Attribute("link") : nullptr;
    const auto link = parent_link != nullptr ? chain_links.find(parent_link) : chain_links.end();
    if (link == chain_links.end()) {
      throw CalibrationError(source + ": joint '" + joint.name + "' has no parent link on the chain");
    }
    // T_parent_joint = T_body,parent_link · O with the fixed joints between merged in, and links
    // keep their place on their body, so the joint's own origin is T_body,parent_link⁻¹ · M'.
    const Transform corrected = inverse(link->second->T_body_link) * corrected_chain.joint(i).T_parent_joint;
    tinyxml2::XMLElement* origin = element->FirstChildElement("origin");
    std::string was = "no origin";
    if (origin == nullptr) {
      origin = doc.NewElement("origin");
      element->InsertFirstChild(origin);
    } else {
      const char* xyz = origin->Attribute("xyz");
      const char* rpy = origin->Attribute("rpy");
      was = std::string("xyz=\"") + (xyz ? xyz : "0 0 0") + "\" rpy=\"" + (rpy ? rpy : "0 0 0") + "\"";
    }
    set_origin(origin, corrected);
    comment_before(origin, "chasles_calibrate: origin was " + was);
  }

  // The marker: a fixed joint from the tip, then an empty link.
  robot->InsertEndChild(doc.NewComment(" chasles_calibrate: the tracked marker (T_tip_marker) "));
  tinyxml2::XMLElement* joint = doc.NewElement("joint");
  joint->SetAttribute("name", options.marker_joint.c_str());
  joint->SetAttribute("type", "fixed");
  tinyxml2::XMLElement* parent = joint->InsertNewChildElement("parent");
  parent->SetAttribute("link", nominal.tip_link().c_str());
  tinyxml2::XMLElement* child = joint->InsertNewChildElement("child");
  child->SetAttribute("link", options.marker_link.c_str());
  set_origin(joint->InsertNewChildElement("origin"), corrections.T_tip_marker);
  robot->InsertEndChild(joint);
  tinyxml2::XMLElement* marker = doc.NewElement("link");
  marker->SetAttribute("name", options.marker_link.c_str());
  robot->InsertEndChild(marker);

  std::string summary =
      " Calibrated by chasles_calibrate: the origins of the movable joints between '" + nominal.base_link() +
      "' and '" + nominal.tip_link() +
      "' carry the fitted corrections and joint zero offsets (the original values are in a comment "
      "beside each); joint '" + options.marker_joint + "' and link '" + options.marker_link +
      "' place the tracked marker on '" + nominal.tip_link() +
      "'. The tracker-to-base transform is not part of the robot: see the report (T_tracker_base). ";
  if (!options.note.empty()) summary += options.note + " ";
  robot->InsertFirstChild(doc.NewComment(comment_safe(summary).c_str()));

  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return std::string(printer.CStr(), static_cast<size_t>(printer.CStrSize() > 0 ? printer.CStrSize() - 1 : 0));
}

std::string identified_urdf(const std::string& original_xml, const RobotModel& identified,
                            const Eigen::VectorXd& viscous, const Eigen::VectorXd& coulomb, const std::string& note) {
  const std::string& source = identified.description().source;
  const int n = identified.dof();
  if (viscous.size() != n || coulomb.size() != n) {
    throw CalibrationError(source + ": " + std::to_string(viscous.size()) + " viscous and " +
                           std::to_string(coulomb.size()) + " Coulomb friction values for a chain of " +
                           std::to_string(n) + " joints");
  }
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLElement* robot = parsed_robot(doc, original_xml, source);
  std::map<std::string, tinyxml2::XMLElement*> joints, links;
  std::multimap<std::string, tinyxml2::XMLElement*> children;  // parent link → its joints
  for (auto* e = robot->FirstChildElement("joint"); e != nullptr; e = e->NextSiblingElement("joint")) {
    const char* name = e->Attribute("name");
    const tinyxml2::XMLElement* parent = e->FirstChildElement("parent");
    if (name == nullptr) continue;
    joints[name] = e;
    if (parent != nullptr && parent->Attribute("link") != nullptr) children.emplace(parent->Attribute("link"), e);
  }
  for (auto* e = robot->FirstChildElement("link"); e != nullptr; e = e->NextSiblingElement("link")) {
    if (const char* name = e->Attribute("name")) links[name] = e;
  }
  std::map<std::string, int> chain_joints;
  std::vector<std::string> body_link(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) chain_joints[identified.joint(i).name] = i;
  for (const ChainLink& link : identified.links()) {
    if (link.body > 0 && body_link[static_cast<size_t>(link.body - 1)].empty()) {
      body_link[static_cast<size_t>(link.body - 1)] = link.name;
    }
  }
  for (int i = 0; i < n; ++i) {
    if (!links.count(body_link[static_cast<size_t>(i)])) {
      throw CalibrationError(source + ": no link '" + body_link[static_cast<size_t>(i)] + "' in the XML");
    }
    if (!joints.count(identified.joint(i).name)) {
      throw CalibrationError(source + ": no joint '" + identified.joint(i).name + "' in the XML");
    }
  }

  // What rides on each body as the original has it: the same document without the <inertial>s
  // of the links that start a body, through the loader, so that fixed joints, rpy and the links
  // off the chain are placed exactly as for the model.
  Eigen::MatrixXd rider_inertia(6 * n, 6);
  {
    tinyxml2::XMLDocument without;
    without.Parse(original_xml.c_str(), original_xml.size());
    for (auto* e = without.FirstChildElement("robot")->FirstChildElement("link"); e != nullptr;
         e = e->NextSiblingElement("link")) {
      const char* name = e->Attribute("name");
      if (name == nullptr || std::find(body_link.begin(), body_link.end(), name) == body_link.end()) continue;
      if (tinyxml2::XMLElement* inertial = e->FirstChildElement("inertial")) e->DeleteChild(inertial);
    }
    tinyxml2::XMLPrinter printer;
    without.Print(&printer);
    UrdfOptions options;
    options.tip_link = identified.tip_link();
    options.gravity = identified.gravity();
    const RobotModel riding = load_urdf_string(printer.CStr(), options, source);
    for (int i = 0; i < n; ++i) rider_inertia.middleRows<6>(6 * i) = riding.inertia(i);
  }

  for (int i = 0; i < n; ++i) {
    const std::string& name = body_link[static_cast<size_t>(i)];
    // The link's own share: the body less its riders, in the link frame (the body's).
    const SpatialInertia G = SpatialInertia::from_matrix(identified.inertia(i) - rider_inertia.middleRows<6>(6 * i));
    if (!(G.mass > 0.0)) {
      std::string list;
      for (const std::string& rider : riders(name, children, links, chain_joints)) {
        list += (list.empty() ? "'" : ", '") + rider + "'";
      }
      char masses[80];
      std::snprintf(masses, sizeof masses, "%.4g kg, no more than the %.4g kg", identified.body_inertia(i).mass,
                    identified.body_inertia(i).mass - G.mass);
      throw CalibrationError(source + ": the identified body moved by joint '" + identified.joint(i).name +
                             "' weighs " + masses + " of the links riding on it in the URDF (" + list +
                             "): either their <inertial>s are not what the arm carries — correct them, or remove "
                             "them to leave the whole body on '" + name + "' — or the log did not determine the "
                             "body well enough: run a longer or faster excitation");
    }
    const Vector3d c = G.h / G.mass;
    const Matrix3d I_c = G.I - G.mass * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
    tinyxml2::XMLElement* link = links.at(name);
    tinyxml2::XMLElement* inertial = replaced_child(link, "inertial", "chasles_calibrate dynamics: identified body");
    inertial->DeleteChildren();
    tinyxml2::XMLElement* origin = inertial->InsertNewChildElement("origin");
    origin->SetAttribute("xyz", triple(c).c_str());
    origin->SetAttribute("rpy", "0 0 0");
    inertial->InsertNewChildElement("mass")->SetAttribute("value", shortest_number(G.mass).c_str());
    tinyxml2::XMLElement* inertia = inertial->InsertNewChildElement("inertia");
    const char* names[6] = {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"};
    const double values[6] = {I_c(0, 0), I_c(0, 1), I_c(0, 2), I_c(1, 1), I_c(1, 2), I_c(2, 2)};
    for (int k = 0; k < 6; ++k) inertia->SetAttribute(names[k], shortest_number(values[k]).c_str());
  }

  for (int i = 0; i < n; ++i) {
    tinyxml2::XMLElement* joint = joints.at(identified.joint(i).name);
    tinyxml2::XMLElement* dynamics =
        replaced_child(joint, "dynamics", "chasles_calibrate dynamics: identified friction");
    dynamics->SetAttribute("damping", shortest_number(viscous[i]).c_str());
    dynamics->SetAttribute("friction", shortest_number(coulomb[i]).c_str());
  }

  // Rotors: the transmission the loader would read for each joint, or a new one.
  std::map<std::string, bool> transmission_names;
  std::vector<tinyxml2::XMLElement*> actuator(static_cast<size_t>(n), nullptr);
  for (auto* t = robot->FirstChildElement("transmission"); t != nullptr; t = t->NextSiblingElement("transmission")) {
    if (const char* name = t->Attribute("name")) transmission_names[name] = true;
    const tinyxml2::XMLElement* joint = t->FirstChildElement("joint");
    const char* joint_name = joint != nullptr ? joint->Attribute("name") : nullptr;
    const auto chain = joint_name != nullptr ? chain_joints.find(joint_name) : chain_joints.end();
    if (chain == chain_joints.end()) continue;
    for (auto* a = t->FirstChildElement("actuator"); a != nullptr; a = a->NextSiblingElement("actuator")) {
      if (a->FirstChildElement("drake:rotor_inertia") || a->FirstChildElement("drake:gear_ratio")) {
        actuator[static_cast<size_t>(chain->second)] = a;
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    const double armature = identified.armature()[i];
    const std::string& joint = identified.joint(i).name;
    if (tinyxml2::XMLElement* a = actuator[static_cast<size_t>(i)]) {
      comment_before(a, "chasles_calibrate dynamics: identified armature " + shortest_number(armature) +
                            " = rotor_inertia * gear_ratio^2; was " + element_text(a));
      tinyxml2::XMLElement* gear = a->FirstChildElement("drake:gear_ratio");
      double ratio = gear != nullptr ? gear->DoubleAttribute("value", 1.0) : 1.0;
      if (ratio == 0.0) {  // a rotor that does not turn holds no armature: make it turn with the joint
        ratio = 1.0;
        gear->SetAttribute("value", "1");
      }
      const std::string rotor = shortest_number(armature / (ratio * ratio));
      child_element(a, "drake:rotor_inertia")->SetAttribute("value", rotor.c_str());
    } else if (armature > 0.0) {
      const std::string name = joint + "_rotor";
      if (transmission_names.count(name)) {
        throw CalibrationError(source + ": a transmission named '" + name +
                               "' exists already, without a rotor for joint '" + joint + "'");
      }
      if (robot->Attribute("xmlns:drake") == nullptr) robot->SetAttribute("xmlns:drake", "http://drake.mit.edu");
      tinyxml2::XMLElement* transmission = doc.NewElement("transmission");
      transmission->SetAttribute("name", name.c_str());
      transmission->InsertNewChildElement("type")->SetText("transmission_interface/SimpleTransmission");
      transmission->InsertNewChildElement("joint")->SetAttribute("name", joint.c_str());
      tinyxml2::XMLElement* motor = transmission->InsertNewChildElement("actuator");
      motor->SetAttribute("name", (joint + "_motor").c_str());
      motor->InsertNewChildElement("drake:gear_ratio")->SetAttribute("value", "1");
      motor->InsertNewChildElement("drake:rotor_inertia")->SetAttribute("value", shortest_number(armature).c_str());
      const std::string note_text =
          " chasles_calibrate dynamics: the identified armature of '" + joint + "' (gear ratio 1) ";
      robot->InsertEndChild(doc.NewComment(comment_safe(note_text).c_str()));
      robot->InsertEndChild(transmission);
    }
  }

  std::string summary =
      " Identified by chasles_calibrate dynamics: the <inertial> of each link that starts a body between '" +
      identified.base_link() + "' and '" + identified.tip_link() +
      "' holds the identified body less the links riding on it (whose <inertial>s are as they were); each movable "
      "joint's <dynamics> holds its viscous (damping) and Coulomb (friction) friction; each rotor's inertia is in "
      "Drake's drake:rotor_inertia. The original values are in a comment beside each. ";
  if (!note.empty()) summary += note + " ";
  robot->InsertFirstChild(doc.NewComment(comment_safe(summary).c_str()));

  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return std::string(printer.CStr(), static_cast<size_t>(printer.CStrSize() > 0 ? printer.CStrSize() - 1 : 0));
}

}  // namespace chasles
