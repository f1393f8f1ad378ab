#include "chasles/core/calibration/urdf_writer.hpp"

#include <tinyxml2.h>

#include <cmath>
#include <map>

#include "chasles/core/calibration/dataset.hpp"
#include "chasles/core/lie/se3.hpp"

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
  if (doc.Parse(original_xml.c_str(), original_xml.size()) != tinyxml2::XML_SUCCESS) {
    throw CalibrationError(source + ": malformed XML at line " + std::to_string(doc.ErrorLineNum()) + ": " +
                           doc.ErrorName());
  }
  tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) throw CalibrationError(source + ": no <robot> element");
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
    tinyxml2::XMLComment* note = doc.NewComment(comment_safe(" chasles_calibrate: origin was " + was + " ").c_str());
    if (origin->PreviousSibling() != nullptr) {
      element->InsertAfterChild(origin->PreviousSibling(), note);
    } else {
      element->InsertFirstChild(note);
    }
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

}  // namespace chasles
