#include "tools/mujoco/mujoco_plant.hpp"

#include <mujoco/mujoco.h>
#include <tinyxml2.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include <cstdio>
#include <set>

#include "core/dynamics/dynamics.hpp"
#include "core/error.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/number_list.hpp"
#include "core/simulation/environment.hpp"

namespace chasles::plant {
namespace {

constexpr char kPusher[] = "pusher";
// Collision bits: the arm's geoms collide with the scene's and the pusher's, none of them with
// their own kind (contype of one & conaffinity of the other).
constexpr int kArmType = 1, kArmAffinity = 0, kSceneType = 0, kSceneAffinity = 1, kFixedType = 2;
// Where the pusher waits when it presses nothing, m below the world's origin.
constexpr double kParkDepth = 10.0;
// Its mass (kg) and the damping on its slides (N·s/m): under a press of f it comes in at most at
// f / damping, 0.4 m/s for 20 N, and presses with exactly f once at rest.
constexpr double kPusherMass = 0.05, kPusherDamping = 50.0;
// The gap it starts at, outside the surface, m.
constexpr double kPusherGap = 5e-4;

[[noreturn]] void fail(const std::string& urdf_path, const std::string& what) {
  throw ArgumentError("MuJoCo plant (" + urdf_path + "): " + what);
}

// The URDF without its visuals and collisions (chasles's geometry replaces the latter, and MuJoCo
// need not find the meshes), with the compiler options the plant needs: keep every link a body,
// and take inertias from the <inertial> elements alone.
std::string urdf_for_mujoco(const std::string& urdf_path) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(urdf_path.c_str()) != tinyxml2::XML_SUCCESS) fail(urdf_path, std::string("not XML: ") + doc.ErrorStr());
  tinyxml2::XMLElement* robot = doc.RootElement();
  if (robot == nullptr || std::string(robot->Name()) != "robot") fail(urdf_path, "no <robot> root element");
  for (auto* link = robot->FirstChildElement("link"); link != nullptr; link = link->NextSiblingElement("link")) {
    while (auto* e = link->FirstChildElement("visual")) link->DeleteChild(e);
    while (auto* e = link->FirstChildElement("collision")) link->DeleteChild(e);
  }
  while (auto* e = robot->FirstChildElement("mujoco")) robot->DeleteChild(e);
  auto* mujoco = doc.NewElement("mujoco");
  auto* compiler = doc.NewElement("compiler");
  compiler->SetAttribute("fusestatic", "false");
  compiler->SetAttribute("discardvisual", "true");
  compiler->SetAttribute("inertiafromgeom", "false");
  mujoco->InsertEndChild(compiler);
  robot->InsertFirstChild(mujoco);
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

void set_pose(const Transform& T, double pos[3], double quat[4]) {
  const Eigen::Quaterniond r(T.linear());
  for (int k = 0; k < 3; ++k) pos[k] = T.translation()[k];
  quat[0] = r.w(), quat[1] = r.x(), quat[2] = r.y(), quat[3] = r.z();
}

void set_shape(mjSpec* spec, mjsGeom* geom, const geometry::Shape& shape, const std::string& name) {
  using geometry::ShapeKind;
  switch (shape.kind) {
    case ShapeKind::kSphere:
      geom->type = mjGEOM_SPHERE, geom->size[0] = shape.radius;
      return;
    case ShapeKind::kBox:
      geom->type = mjGEOM_BOX;
      for (int k = 0; k < 3; ++k) geom->size[k] = shape.half_extents[k];
      return;
    case ShapeKind::kCylinder:
    case ShapeKind::kCapsule:
      geom->type = shape.kind == ShapeKind::kCylinder ? mjGEOM_CYLINDER : mjGEOM_CAPSULE;
      geom->size[0] = shape.radius, geom->size[1] = shape.half_length;
      return;
    case ShapeKind::kConvex: {
      // MuJoCo collides a mesh as its convex hull: the hull's vertices are all it needs.
      mjsMesh* mesh = mjs_addMesh(spec, nullptr);
      mjs_setName(mesh->element, name.c_str());
      std::vector<float> vertices;
      vertices.reserve(3 * shape.vertices.size());
      for (const Vector3d& v : shape.vertices)
        for (int k = 0; k < 3; ++k) vertices.push_back(static_cast<float>(v[k]));
      mjs_setFloat(mesh->uservert, vertices.data(), static_cast<int>(vertices.size()));
      geom->type = mjGEOM_MESH;
      mjs_setString(geom->meshname, name.c_str());
      return;
    }
  }
}

bool positive(double x) { return x > 0.0 && std::isfinite(x); }

// The scene's faults, named as the caller gave them (objects by name, presses by number).
void check_scene(const MujocoScene& scene, const geometry::CollisionModel& geometry, const std::string& urdf_path) {
  std::set<std::string> names{kPusher};
  for (const geometry::SceneObject& object : scene.objects) {
    const std::string what = "scene object \"" + object.name + "\"";
    if (object.name.empty()) fail(urdf_path, "a scene object has no name");
    if (!names.insert(object.name).second) fail(urdf_path, what + " is named twice (or \"pusher\", the pusher's name)");
    const geometry::Shape& shape = object.shape;
    const bool sized = shape.kind == geometry::ShapeKind::kBox      ? positive(shape.half_extents.minCoeff())
                       : shape.kind == geometry::ShapeKind::kConvex ? shape.vertices.size() >= 4
                       : shape.kind == geometry::ShapeKind::kSphere ? positive(shape.radius)
                                                                    : positive(shape.radius) && positive(shape.half_length);
    if (!sized) fail(urdf_path, what + " has a size that is not finite and > 0");
    if (!object.T_base_object.matrix().allFinite()) fail(urdf_path, what + " has a pose that is not finite");
  }
  if (!(scene.friction >= 0.0) || !std::isfinite(scene.friction)) fail(urdf_path, "the scene's friction must be finite and >= 0");
  if (!(scene.pusher_radius >= 0.0) || !std::isfinite(scene.pusher_radius))
    fail(urdf_path, "the pusher's radius must be finite and >= 0");
  for (size_t k = 0; k < scene.presses.size(); ++k) {
    const Press& press = scene.presses[k];
    const std::string what = "press " + std::to_string(k + 1);
    check_window(press.start, press.duration, press.ramp, what);
    if (scene.pusher_radius <= 0.0) fail(urdf_path, what + ": the scene has no pusher");
    if (!positive(press.force)) fail(urdf_path, what + ": the force must be finite and > 0 N");
    if (!(press.direction.norm() > 0.0) || !press.direction.allFinite() || !press.aim.allFinite())
      fail(urdf_path, what + ": the aim must be finite and the direction finite and not zero");
    const auto on_link = [&](const geometry::CollisionObject& o) { return o.link == press.link; };
    if (std::none_of(geometry.objects.begin(), geometry.objects.end(), on_link))
      fail(urdf_path, what + ": link \"" + press.link + "\" has no collision geometry to press");
    for (size_t j = 0; j < k; ++j) {
      const Press& other = scene.presses[j];
      if (press.start < other.start + other.duration && other.start < press.start + press.duration)
        fail(urdf_path, what + " overlaps press " + std::to_string(j + 1) + " in time: there is one pusher");
    }
  }
}

}  // namespace

struct MujocoPlant::Engine {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  std::vector<int> qpos, dof;            // model joint i's qpos and dof address
  std::vector<std::string> geom_link;    // per MuJoCo geom: the URDF link of an arm geom, or empty
  std::vector<std::string> geom_other;   // per MuJoCo geom: a scene geom's name, or empty
  std::vector<int> geom_body;            // per MuJoCo geom: the chain body an arm geom rides on, or −1
  int pusher_body = -1, pusher_dof = -1, pusher_qpos = -1;
  Transform T_world_base = Transform::Identity();
  Vector3d push = Vector3d::Zero();      // the pusher's force, world frame
  Vector3d push_direction = Vector3d::Zero();  // unit, world frame, of the press under way
  Eigen::Matrix<double, 3, Eigen::Dynamic> jacp;  // one point's translational Jacobian, 3 × nv
  ~Engine() {
    mj_deleteData(d);
    mj_deleteModel(m);
  }
};

MujocoPlant::MujocoPlant(const RobotModel& model, const std::string& urdf_path,
                         const geometry::CollisionModel& geometry, const MujocoScene& scene,
                         const Eigen::VectorXd& q0, const Eigen::VectorXd& damping, double dt)
    : model_(model), dt_(dt), engine_(std::make_unique<Engine>()), data_(model) {
  const int n = model.dof();
  check_scene(scene, geometry, urdf_path);
  if (q0.size() != n || damping.size() != n)
    fail(urdf_path, "q0 and damping need " + std::to_string(n) + " entries, one per joint");
  if (!(dt > 0.0) || !std::isfinite(dt)) fail(urdf_path, "the step must be a finite time > 0");

  char error[1024] = "";
  const std::string xml = urdf_for_mujoco(urdf_path);
  mjSpec* spec = mj_parseXMLString(xml.c_str(), nullptr, error, sizeof error);
  if (spec == nullptr) fail(urdf_path, std::string("MuJoCo cannot read it: ") + error);
  struct SpecDeleter {
    mjSpec* s;
    ~SpecDeleter() { mj_deleteSpec(s); }
  } spec_deleter{spec};

  // Joints the model does not have are welded at their zero.
  std::vector<mjsElement*> extra_joints;
  for (mjsElement* e = mjs_firstElement(spec, mjOBJ_JOINT); e != nullptr; e = mjs_nextElement(spec, e))
    if (model.joint_index(mjs_getString(mjs_getName(e))) < 0) extra_joints.push_back(e);
  for (mjsElement* e : extra_joints) mjs_delete(spec, e);

  // The arm's collision objects, on the bodies of the links chasles places them on.
  std::vector<std::string> body_link(static_cast<size_t>(n) + 1);
  body_link[0] = model.base_link();
  for (int i = 1; i <= n; ++i)
    for (const ChainLink& link : model.links())
      if (link.body == i && link.T_body_link.linear() == Matrix3d::Identity() &&
          link.T_body_link.translation() == Vector3d::Zero()) {
        body_link[static_cast<size_t>(i)] = link.name;
        break;
      }
  for (const geometry::CollisionObject& object : geometry.objects) {
    mjsBody* body = mjs_findBody(spec, body_link[static_cast<size_t>(object.body)].c_str());
    if (body == nullptr) fail(urdf_path, "MuJoCo has no body for link " + body_link[static_cast<size_t>(object.body)]);
    mjsGeom* geom = mjs_addGeom(body, nullptr);
    mjs_setName(geom->element, object.name.c_str());
    set_pose(object.T_body_object, geom->pos, geom->quat);
    set_shape(spec, geom, object.shape, object.name);
    // The base's own objects never move: what they touch pushes no joint, and is left out (a bit
    // nothing has in its affinity; not 0, which discardvisual would take for a visual and drop).
    geom->contype = object.body == 0 ? kFixedType : kArmType, geom->conaffinity = kArmAffinity;
    geom->friction[0] = scene.friction;
  }

  // The scene, on a body fixed to the base link: its objects are placed in the base frame where the
  // model is compiled, as MuJoCo's static bounding volumes need (a geom moved after mj_compile is
  // missed by the broad phase).
  mjsBody* world = mjs_findBody(spec, "world");
  mjsBody* base_body = mjs_findBody(spec, body_link[0].c_str());
  if (base_body == nullptr) fail(urdf_path, "MuJoCo has no body for the base link " + body_link[0]);
  mjsBody* scene_body = mjs_addBody(base_body, nullptr);
  mjs_setName(scene_body->element, "scene");
  for (const geometry::SceneObject& object : scene.objects) {
    mjsGeom* geom = mjs_addGeom(scene_body, nullptr);
    mjs_setName(geom->element, object.name.c_str());
    set_pose(object.T_base_object, geom->pos, geom->quat);
    set_shape(spec, geom, object.shape, "scene:" + object.name);
    geom->contype = kSceneType, geom->conaffinity = kSceneAffinity;
    geom->friction[0] = scene.friction;
  }
  if (scene.pusher_radius > 0.0) {
    mjsBody* pusher = mjs_addBody(world, nullptr);
    mjs_setName(pusher->element, kPusher);
    pusher->pos[2] = -kParkDepth;
    pusher->mass = kPusherMass;
    pusher->gravcomp = 1.0;
    for (int k = 0; k < 3; ++k) {
      pusher->inertia[k] = 0.4 * kPusherMass * scene.pusher_radius * scene.pusher_radius;
      mjsJoint* slide = mjs_addJoint(pusher, nullptr);
      slide->type = mjJNT_SLIDE;
      slide->axis[0] = k == 0, slide->axis[1] = k == 1, slide->axis[2] = k == 2;
      slide->damping = kPusherDamping;
    }
    mjsGeom* ball = mjs_addGeom(pusher, nullptr);
    mjs_setName(ball->element, kPusher);
    ball->type = mjGEOM_SPHERE, ball->size[0] = scene.pusher_radius;
    ball->contype = kSceneType, ball->conaffinity = kSceneAffinity;
    ball->friction[0] = scene.friction;
  }
  spec->option.timestep = dt;
  spec->option.integrator = mjINT_IMPLICITFAST;
  spec->option.cone = mjCONE_ELLIPTIC;
  spec->option.noslip_iterations = 20;

  Engine& e = *engine_;
  e.m = mj_compile(spec, nullptr);
  if (e.m == nullptr) fail(urdf_path, std::string("MuJoCo cannot compile it: ") + mjs_getError(spec));
  e.d = mj_makeData(e.m);
  const mjModel* m = e.m;

  for (int i = 0; i < n; ++i) {
    const int j = mj_name2id(m, mjOBJ_JOINT, model.joint(i).name.c_str());
    if (j < 0) fail(urdf_path, "MuJoCo has no joint " + model.joint(i).name);
    e.qpos.push_back(m->jnt_qposadr[j]);
    e.dof.push_back(m->jnt_dofadr[j]);
    e.m->dof_armature[m->jnt_dofadr[j]] = model.armature()[i];
    e.m->dof_damping[m->jnt_dofadr[j]] = damping[i];
  }
  e.geom_link.resize(static_cast<size_t>(m->ngeom));
  e.geom_other.resize(static_cast<size_t>(m->ngeom));
  e.geom_body.assign(static_cast<size_t>(m->ngeom), -1);
  const auto geom_id = [&](const std::string& name) {
    const int g = mj_name2id(m, mjOBJ_GEOM, name.c_str());
    if (g < 0) fail(urdf_path, "MuJoCo dropped the geom " + name);
    return static_cast<size_t>(g);
  };
  for (const geometry::CollisionObject& object : geometry.objects) {
    const size_t g = geom_id(object.name);
    e.geom_link[g] = object.link;
    e.geom_body[g] = object.body;
  }
  for (const geometry::SceneObject& object : scene.objects)
    e.geom_other[geom_id(object.name)] = object.name;
  if (scene.pusher_radius > 0.0) {
    e.pusher_body = mj_name2id(m, mjOBJ_BODY, kPusher);
    e.pusher_dof = m->body_dofadr[e.pusher_body];
    e.pusher_qpos = m->jnt_qposadr[m->body_jntadr[e.pusher_body]];
    e.geom_other[static_cast<size_t>(mj_name2id(m, mjOBJ_GEOM, kPusher))] = kPusher;
  }

  // The base's pose in the world at q = 0: gravity and every output turn by it.
  mj_kinematics(e.m, e.d);
  const int base = mj_name2id(m, mjOBJ_BODY, model.base_link().c_str());
  if (base < 0) fail(urdf_path, "MuJoCo has no body for the base link " + model.base_link());
  e.T_world_base.translation() = Eigen::Map<const Vector3d>(e.d->xpos + 3 * base);
  e.T_world_base.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(e.d->xmat + 9 * base);
  const Vector3d g_world = e.T_world_base.linear() * model.gravity();
  for (int k = 0; k < 3; ++k) e.m->opt.gravity[k] = g_world[k];

  for (int i = 0; i < n; ++i) e.d->qpos[e.qpos[static_cast<size_t>(i)]] = q0[i];
  e.jacp.resize(3, m->nv);
  q_ = q0;
  qd_ = Eigen::VectorXd::Zero(n);
  effort_ = Eigen::VectorXd::Zero(n);
  brake_ = Eigen::VectorXd::Zero(n);
  truth_.tau_ext = Eigen::VectorXd::Zero(n);
  truth_.contacts.reserve(256);
  effort_limit_.resize(n);
  for (int i = 0; i < n; ++i) effort_limit_[i] = model.joint(i).limits.effort;
  presses_ = scene.presses;
  press_started_.assign(presses_.size(), false);
  has_environment_ = !scene.objects.empty() || scene.pusher_radius > 0.0;
  mj_forward(e.m, e.d);
  read_contacts();
}

MujocoPlant::~MujocoPlant() = default;

double MujocoPlant::time() const { return engine_->d->time; }

void MujocoPlant::step(const Eigen::Ref<const Eigen::VectorXd>& tau) {
  Engine& e = *engine_;
  follow_presses();
  effort_ = tau.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
  for (int i = 0; i < model_.dof(); ++i) e.d->qfrc_applied[e.dof[static_cast<size_t>(i)]] = effort_[i];
  if (e.pusher_dof >= 0)
    for (int k = 0; k < 3; ++k) e.d->qfrc_applied[e.pusher_dof + k] = e.push[k];
  mj_step(e.m, e.d);
  // mj_step leaves the contacts of the state it started from: find those of the new one.
  mj_forward(e.m, e.d);
  ++steps_;
  read_state();
  read_contacts();
}

// The schedule: a press starts the first step its window covers (at the step's start), follows
// its ramps, and ends with its window. A press whose line meets something else first is skipped,
// said once.
void MujocoPlant::follow_presses() {
  Engine& e = *engine_;
  const double t = time();
  int due = -1;
  double profile = 0.0;
  for (size_t k = 0; k < presses_.size() && due < 0; ++k) {
    const Press& p = presses_[k];
    profile = trapezoid(t, p.start, p.duration, p.ramp);
    if (profile > 0.0) due = static_cast<int>(k);
  }
  if (due != active_press_) {
    if (active_press_ >= 0) release();
    active_press_ = -1;
    if (due >= 0 && !press_started_[static_cast<size_t>(due)]) {
      press_started_[static_cast<size_t>(due)] = true;
      const Press& p = presses_[static_cast<size_t>(due)];
      try {
        press(p.link, p.aim, p.direction, p.force);
        active_press_ = due;
      } catch (const ArgumentError& error) {
        ++presses_skipped_;
        std::fprintf(stderr, "chasles_plant: press %d skipped: %s\n", due + 1, error.what());
      }
    }
  }
  if (active_press_ >= 0) e.push = profile * presses_[static_cast<size_t>(active_press_)].force * e.push_direction;
}

const Eigen::VectorXd& MujocoPlant::brake_torque(double time_constant) {
  brake_ = gravity_torques(model_, data_, q_);
  brake_.noalias() -= (1.0 / time_constant) * mass_matrix(model_, data_, q_) * qd_;
  return brake_;
}

const Truth& MujocoPlant::sample_truth() {
  truth_.steps = steps_;
  truth_.time = time();
  return truth_;
}

void MujocoPlant::read_state() {
  const Engine& e = *engine_;
  for (int i = 0; i < model_.dof(); ++i) {
    q_[i] = e.d->qpos[e.qpos[static_cast<size_t>(i)]];
    qd_[i] = e.d->qvel[e.dof[static_cast<size_t>(i)]];
  }
}

void MujocoPlant::read_contacts() {
  Engine& e = *engine_;
  const mjModel* m = e.m;
  mjData* d = e.d;
  truth_.contacts.clear();
  truth_.tau_ext.setZero();
  truth_.tip_wrench_ext.setZero();
  bool tip_known = false;  // the tip's origin, computed for the first contact on its body
  Vector3d p_tip = Vector3d::Zero();
  const Eigen::Matrix3d R_base_world = e.T_world_base.linear().transpose();
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& contact = d->contact[c];
    if (contact.efc_address < 0) continue;  // within the margin, or excluded: no force
    const std::string& link1 = e.geom_link[static_cast<size_t>(contact.geom[0])];
    const std::string& link2 = e.geom_link[static_cast<size_t>(contact.geom[1])];
    if (link1.empty() == link2.empty()) continue;  // neither on the arm (or both, which cannot be)
    const bool arm_first = !link1.empty();
    const int arm_geom = contact.geom[arm_first ? 0 : 1];
    mjtNum local[6];
    mj_contactForce(m, d, c, local);
    // The frame's rows are the normal (from geom 1 to geom 2) and two tangents; the force is the
    // one on geom 2.
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(contact.frame);
    const double sign = arm_first ? -1.0 : 1.0;
    const Vector3d force_world = sign * (frame.transpose() * Vector3d(local[0], local[1], local[2]));
    const Vector3d point_world = Eigen::Map<const Vector3d>(contact.pos);
    ArmContact out;
    out.link = arm_first ? link1 : link2;
    out.other = e.geom_other[static_cast<size_t>(contact.geom[arm_first ? 1 : 0])];
    out.point = R_base_world * (point_world - e.T_world_base.translation());
    out.normal = R_base_world * (sign * frame.row(0).transpose());
    out.force = R_base_world * force_world;
    truth_.contacts.push_back(out);
    if (e.geom_body[static_cast<size_t>(arm_geom)] == model_.dof()) {
      if (!tip_known) p_tip = forward_kinematics(model_, data_, q_).translation(), tip_known = true;
      truth_.tip_wrench_ext.head<3>() += (out.point - p_tip).cross(out.force);
      truth_.tip_wrench_ext.tail<3>() += out.force;
    }
    mj_jac(m, d, e.jacp.data(), nullptr, contact.pos, m->geom_bodyid[arm_geom]);
    // jacp is 3 × nv row-major in MuJoCo's terms: Eigen's column-major 3 × nv holds its transpose
    // read back as nv × 3; map it as MuJoCo wrote it.
    const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> J(e.jacp.data(), 3, m->nv);
    for (int i = 0; i < model_.dof(); ++i)
      truth_.tau_ext[i] += J.col(e.dof[static_cast<size_t>(i)]).dot(force_world);
  }
  truth_.contact = !truth_.contacts.empty();
}

void MujocoPlant::press(const std::string& link, const Vector3d& aim, const Vector3d& direction, double force) {
  Engine& e = *engine_;
  if (e.pusher_body < 0) throw ArgumentError("MuJoCo plant: the scene has no pusher");
  if (!(force > 0.0) || !std::isfinite(force)) throw ArgumentError("MuJoCo plant: a press needs a finite force > 0 N");
  if (!(direction.norm() > 0.0) || !direction.allFinite())
    throw ArgumentError("MuJoCo plant: a press needs a direction");
  if (std::find(e.geom_link.begin(), e.geom_link.end(), link) == e.geom_link.end())
    throw ArgumentError("MuJoCo plant: link " + link + " has no collision geometry to press");
  release();
  mj_forward(e.m, e.d);
  // The link's pose: that of any of its geoms' body, with the geom's placement undone.
  int link_geom = 0;
  while (e.geom_link[static_cast<size_t>(link_geom)] != link) ++link_geom;
  const int body = e.m->geom_bodyid[link_geom];
  Transform T_world_body = Transform::Identity();
  T_world_body.translation() = Eigen::Map<const Vector3d>(e.d->xpos + 3 * body);
  T_world_body.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(e.d->xmat + 9 * body);
  Transform T_body_link = Transform::Identity();
  for (const ChainLink& l : model_.links())
    if (l.name == link) T_body_link = l.T_body_link;
  const Vector3d dir_world = e.T_world_base.linear() * direction.normalized();
  const Vector3d aim_world = T_world_body * (T_body_link * aim);
  // Along the line from 2 m out, the first thing hit must be the link.
  const Vector3d from = aim_world - 2.0 * dir_world;
  int hit = -1;
  const mjtNum distance = mj_ray(e.m, e.d, from.data(), dir_world.data(), nullptr, 1, e.pusher_body, &hit);
  if (hit < 0) throw ArgumentError("MuJoCo plant: the line of the press misses " + link);
  const std::string& met = e.geom_link[static_cast<size_t>(hit)];
  if (met != link)
    throw ArgumentError("MuJoCo plant: the line of the press meets " +
                        (met.empty() ? e.geom_other[static_cast<size_t>(hit)] : met) + " before " + link);
  const double radius = e.m->geom_size[3 * e.m->body_geomadr[e.pusher_body]];
  const Vector3d centre = from + (distance - radius - kPusherGap) * dir_world;
  for (int k = 0; k < 3; ++k) {
    e.d->qpos[e.pusher_qpos + k] = centre[k] - (k == 2 ? -kParkDepth : 0.0);
    e.d->qvel[e.pusher_dof + k] = 0.0;
  }
  e.push_direction = dir_world;
  e.push = force * dir_world;
  mj_forward(e.m, e.d);
}

void MujocoPlant::release() {
  Engine& e = *engine_;
  if (e.pusher_body < 0) return;
  e.push.setZero();
  for (int k = 0; k < 3; ++k) e.d->qpos[e.pusher_qpos + k] = 0.0, e.d->qvel[e.pusher_dof + k] = 0.0;
}

Press parse_press(const std::string& text) {
  const size_t comma = text.find(',');
  Press press;
  press.link = text.substr(0, comma);
  if (press.link.empty() || comma == std::string::npos)
    throw ArgumentError("--press takes LINK,START,DURATION,RAMP,AX,AY,AZ,DX,DY,DZ,FORCE: a link's name first");
  const std::vector<double> v = parse_number_list(text.substr(comma + 1), "--press " + press.link);
  if (v.size() != 10) {
    throw ArgumentError("--press takes LINK,START,DURATION,RAMP,AX,AY,AZ,DX,DY,DZ,FORCE: after the link 10 numbers "
                        "(s, s, s, the aim in the link's frame in m, the direction in the base frame, N), not " +
                        std::to_string(v.size()));
  }
  press.start = v[0], press.duration = v[1], press.ramp = v[2];
  press.aim = Vector3d(v[3], v[4], v[5]);
  press.direction = Vector3d(v[6], v[7], v[8]);
  press.force = v[9];
  check_window(press.start, press.duration, press.ramp, "--press " + press.link);
  if (!(press.force > 0.0)) throw ArgumentError("--press " + press.link + ": FORCE must be > 0 N");
  if (!(press.direction.norm() > 0.0)) throw ArgumentError("--press " + press.link + ": the direction is zero");
  return press;
}

}  // namespace chasles::plant
