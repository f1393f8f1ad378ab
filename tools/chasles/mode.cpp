// chasles mode and chasles payload: the controller's control law (one control_mode_t on
// <prefix>MODE) and the load at the arm's tip (one payload_t on <prefix>PAYLOAD).
//
// The message is built and encoded, and the very bytes that will be sent are judged first by the
// controller's own reader: the checked decoder (lcmtypes/checked.hpp), then for a mode
// law_from_message and law_problem, for a payload payload_problem. A refusal is therefore the one
// the controller would give, word for word, and a refused message is never sent. What the
// controller can only judge once it runs (whether it has a state yet, whether it is in FAULT) is
// for it to answer, in its status.
#include <lcm/lcm.h>

#include <chasles/control_mode_t.hpp>
#include <chasles/payload_t.hpp>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <cstdio>
#include <string>
#include <vector>

#include "controller/law.hpp"
#include "controller/transport/lcm_io.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/model/payload.hpp"
#include "core/number_list.hpp"
#include "lcmtypes/checked.hpp"
#include "command.hpp"
#include "lcm_start.hpp"

namespace chasles::cli {
namespace {

using controller::Law;
using controller::LawBounds;
using controller::LawDefaults;

// A bound or default as the help text quotes it.
std::string quote(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", x);
  return text;
}

std::vector<double> numbers(const std::string& text, const std::string& option) {
  try {
    return parse_number_list(text, option);
  } catch (const ArgumentError& e) {
    throw InputError(e.what());
  }
}

double one_number(const std::string& text, const std::string& option) {
  const std::vector<double> values = numbers(text, option);
  if (values.size() != 1) {
    throw InputError(option + " takes one number; got " + std::to_string(values.size()));
  }
  return values[0];
}

// One value for every joint ("100") or one per joint, root to tip ("100,200,...").
std::vector<double> joint_values(const std::string& text, int n, const std::string& option) {
  std::vector<double> values = numbers(text, option);
  if (values.size() == 1) return std::vector<double>(size_t(n), values[0]);
  if (values.size() != size_t(n)) {
    throw InputError(option + " has " + std::to_string(values.size()) + " entries; give one for every joint or " +
                     std::to_string(n) + ", one per joint, root to tip");
  }
  return values;
}

bool all_zero(const std::vector<double>& values) {
  for (const double x : values) {
    if (x != 0.0) return false;
  }
  return true;
}

template <typename Message>
std::vector<uint8_t> encode(const Message& message) {
  std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
  if (message.encode(bytes.data(), 0, static_cast<int>(bytes.size())) != static_cast<int>(bytes.size())) {
    throw std::runtime_error(std::string(Message::getTypeName()) + " did not encode");
  }
  return bytes;
}

// Sends the bytes already checked, as they are.
void publish(const WireOptions& wire, const std::string& channel, const std::vector<uint8_t>& bytes) {
  lcm_t* lcm = start_lcm(wire.lcm_url);
  const int status = lcm_publish(lcm, channel.c_str(), bytes.data(), static_cast<unsigned int>(bytes.size()));
  lcm_destroy(lcm);
  if (status != 0) {
    throw InputError("cannot publish on " + channel + (wire.lcm_url.empty() ? "" : " on " + wire.lcm_url));
  }
}

// ---- chasles mode ----

struct ModeOptions {
  std::string law;
  ModelOptions model;
  std::string stiffness, damping, damping_ratio;
  std::string translational, rotational, cartesian_stiffness, frame;
  std::string posture, nullspace_stiffness;
  WireOptions wire;
};

// An option that only some laws read, and which.
struct LawOption {
  const CLI::Option* option;
  std::vector<Law> laws;
};

std::string law_names(const std::vector<Law>& laws) {
  std::string names;
  for (size_t i = 0; i < laws.size(); ++i) {
    names += (i == 0 ? "" : i + 1 == laws.size() ? " and " : ", ") + std::string(controller::to_string(laws[i]));
  }
  return names;
}

// The message the options ask for, not yet judged (the bounds and the meaning are law_problem's).
control_mode_t mode_message(const ModeOptions& o, Law law, const RobotModel& model) {
  const int n = model.dof();
  control_mode_t m{};
  m.law = controller::to_wire(law);
  m.num_joints = 0;
  m.damping_ratio = o.damping_ratio.empty() ? LawDefaults::kDampingRatio : one_number(o.damping_ratio, "--damping-ratio");
  m.stiffness_frame_quaternion[0] = 1.0;  // the tip frame itself, for every law
  m.num_posture = 0;
  m.nullspace_stiffness = 0.0;

  // All zero on the wire means "from the damping ratio" (joint impedance) or "the default"
  // (free drive): an explicit --damping 0 would silently mean that instead.
  const auto damping = [&] {
    std::vector<double> d = joint_values(o.damping, n, "--damping");
    if (all_zero(d)) {
      throw InputError("--damping is 0 for every joint, which the controller reads as no damping given; omit --damping "
                       "for that");
    }
    return d;
  };
  switch (law) {
    case Law::kComputedTorque:
      break;
    case Law::kJointImpedance:
      if (o.stiffness.empty()) {
        throw InputError("joint-impedance needs --stiffness (N*m/rad, one for every joint or one per joint)");
      }
      m.num_joints = n;
      m.joint_stiffness = joint_values(o.stiffness, n, "--stiffness");
      m.joint_damping = o.damping.empty() ? std::vector<double>(size_t(n), 0.0) : damping();
      break;
    case Law::kFreeDrive:
      if (!o.damping.empty()) {
        m.num_joints = n;
        m.joint_stiffness.assign(size_t(n), 0.0);
        m.joint_damping = damping();
      }
      break;
    case Law::kCartesianImpedance: {
      if (!o.cartesian_stiffness.empty()) {
        const std::vector<double> k = numbers(o.cartesian_stiffness, "--cartesian-stiffness");
        if (k.size() == 6) {
          for (int i = 0; i < 6; ++i) m.cartesian_stiffness[i][i] = k[size_t(i)];
        } else if (k.size() == 36) {
          for (int r = 0; r < 6; ++r) {
            for (int c = 0; c < 6; ++c) m.cartesian_stiffness[r][c] = k[size_t(6 * r + c)];
          }
        } else {
          throw InputError("--cartesian-stiffness has " + std::to_string(k.size()) +
                           " entries; give 6 (the diagonal, rotational first) or 36 (the matrix, row by row)");
        }
      } else {
        const double rotational =
            o.rotational.empty() ? LawDefaults::kRotationalStiffness : one_number(o.rotational, "--rotational");
        const double translational = o.translational.empty() ? LawDefaults::kTranslationalStiffness
                                                             : one_number(o.translational, "--translational");
        for (int i = 0; i < 3; ++i) {
          m.cartesian_stiffness[i][i] = rotational;
          m.cartesian_stiffness[i + 3][i + 3] = translational;
        }
      }
      if (!o.frame.empty()) {
        const std::vector<double> f = numbers(o.frame, "--frame");
        if (f.size() != 3 && f.size() != 7) {
          throw InputError("--frame has " + std::to_string(f.size()) +
                           " entries; give X,Y,Z (m) or X,Y,Z,QW,QX,QY,QZ (m and a unit quaternion)");
        }
        for (int i = 0; i < 3; ++i) m.stiffness_frame_position[i] = f[size_t(i)];
        for (int i = 0; i < 4 && f.size() == 7; ++i) m.stiffness_frame_quaternion[i] = f[size_t(3 + i)];
      }
      if (!o.posture.empty()) {
        const Eigen::VectorXd q = parse_list(o.posture, n, "--posture");
        m.num_posture = n;
        m.nullspace_posture.assign(q.data(), q.data() + n);
      }
      m.nullspace_stiffness =
          o.nullspace_stiffness.empty() ? LawDefaults::kNullspaceStiffness
                                        : one_number(o.nullspace_stiffness, "--nullspace-stiffness");
      break;
    }
  }
  return m;
}

// The controller's judgement of `bytes`, as its ModeReceiver and Controller::set_law make it; on
// success `settings` holds the law it would run.
void judge_mode(const RobotModel& model, const std::vector<uint8_t>& bytes, control_mode_t& decoded,
                controller::LawSettings& settings) {
  const int n = model.dof();
  if (std::string why = messages::decode_checked(bytes.data(), bytes.size(), decoded, n, messages::Finite::Required);
      !why.empty()) {
    throw InputError("the control_mode_t " + why);
  }
  if (std::string why = controller::law_from_message(decoded, n, settings); !why.empty()) throw InputError(why);
  char why[192];
  if (const char* problem = controller::law_problem(model, settings, why)) throw InputError(problem);
}

Json run_mode(const ModeOptions& o, const std::vector<LawOption>& law_options) {
  const std::string channel = o.wire.prefix + "MODE";
  Law law = Law::kComputedTorque;
  std::vector<uint8_t> bytes;
  control_mode_t sent;
  Json out;
  try {
    if (!controller::parse_law(o.law, law)) {
      throw InputError("unknown law '" + o.law +
                       "' (laws: " + law_names({Law::kComputedTorque, Law::kJointImpedance, Law::kCartesianImpedance,
                                                Law::kFreeDrive}) +
                       ")");
    }
    for (const LawOption& entry : law_options) {
      if (entry.option->count() == 0) continue;
      bool applies = false;
      for (const Law l : entry.laws) applies = applies || l == law;
      if (!applies) {
        throw InputError(entry.option->get_name() + " does not apply to " + controller::to_string(law) +
                         " (only to " + law_names(entry.laws) + ")");
      }
    }
    const RobotModel model = load_model(o.model);  // a ModelError names the file: not prefixed
    const int n = model.dof();
    control_mode_t message = mode_message(o, law, model);
    message.utime = controller::realtime_us();
    controller::LawSettings settings(n);
    // The quaternion as typed first, so that one far from unit norm gets the controller's refusal;
    // then normalised, as the contract asks, and everything judged again on the bytes to be sent.
    if (std::string why = controller::law_from_message(message, n, settings); !why.empty()) throw InputError(why);
    Eigen::Map<Eigen::Vector4d> quaternion(message.stiffness_frame_quaternion);
    const double input_norm = quaternion.norm();
    quaternion /= input_norm;
    bytes = encode(message);
    judge_mode(model, bytes, sent, settings);

    out["channel"] = channel;
    out["utime"] = sent.utime;
    out["law"] = controller::to_string(law);
    Json names = Json::array();
    for (const Joint& joint : model.joints()) names.push_back(joint.name);
    const auto joints = [&](const std::vector<double>& v) {
      return vector_json(Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size())));
    };
    if (sent.num_joints > 0 || sent.num_posture > 0) out["joint_names"] = std::move(names);
    if (law == Law::kJointImpedance) out["joint_stiffness"] = joints(sent.joint_stiffness);
    if (sent.num_joints > 0 && !settings.damping_from_ratio) out["joint_damping"] = joints(sent.joint_damping);
    if (law == Law::kCartesianImpedance || (law == Law::kJointImpedance && settings.damping_from_ratio)) {
      out["damping_ratio"] = sent.damping_ratio;
    }
    if (law == Law::kCartesianImpedance) {
      out["cartesian_stiffness"] = rows_json(settings.cartesian_stiffness);
      out["stiffness_frame_position"] = vector_json(Eigen::Map<const Eigen::Vector3d>(sent.stiffness_frame_position));
      out["stiffness_frame_quaternion"] =
          vector_json(Eigen::Map<const Eigen::Vector4d>(sent.stiffness_frame_quaternion));
      out["quaternion_input_norm"] = input_norm;
      if (sent.num_posture > 0) out["nullspace_posture"] = joints(sent.nullspace_posture);
      out["nullspace_stiffness"] = sent.nullspace_stiffness;
    }
  } catch (const InputError& e) {
    throw InputError(std::string("mode: ") + e.what());
  }
  publish(o.wire, channel, bytes);
  return out;
}

// ---- chasles payload ----

struct PayloadOptions {
  std::string mass, com, inertia;
  WireOptions wire;
};

Json run_payload(const PayloadOptions& o) {
  const std::string channel = o.wire.prefix + "PAYLOAD";
  std::vector<uint8_t> bytes;
  payload_t sent;
  try {
    payload_t message{};
    message.mass = one_number(o.mass, "--mass") + 0.0;  // + 0.0: -0 is sent as 0
    if (message.mass == 0.0 && (!o.com.empty() || !o.inertia.empty())) {
      throw InputError("--mass 0 removes the payload; it takes no --com or --inertia");
    }
    if (!o.com.empty()) {
      const std::vector<double> c = numbers(o.com, "--com");
      if (c.size() != 3) throw InputError("--com has " + std::to_string(c.size()) + " entries; give X,Y,Z (m)");
      for (int i = 0; i < 3; ++i) message.centre_of_mass[i] = c[size_t(i)];
    }
    if (!o.inertia.empty()) {
      const std::vector<double> I = numbers(o.inertia, "--inertia");
      if (I.size() != 3 && I.size() != 6) {
        throw InputError("--inertia has " + std::to_string(I.size()) +
                         " entries; give IXX,IYY,IZZ or IXX,IYY,IZZ,IXY,IXZ,IYZ (kg*m^2)");
      }
      const double ixy = I.size() == 6 ? I[3] : 0.0, ixz = I.size() == 6 ? I[4] : 0.0, iyz = I.size() == 6 ? I[5] : 0.0;
      const double rows[3][3] = {{I[0], ixy, ixz}, {ixy, I[1], iyz}, {ixz, iyz, I[2]}};
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) message.inertia[r][c] = rows[r][c];
      }
    }
    message.utime = controller::realtime_us();
    bytes = encode(message);
    // As the controller's PayloadReceiver reads it.
    if (std::string why = messages::decode_checked(bytes.data(), bytes.size(), sent, messages::kAnyArm,
                                                   messages::Finite::Required);
        !why.empty()) {
      throw InputError("the payload_t " + why);
    }
    Payload payload;
    payload.mass = sent.mass;
    payload.centre = Eigen::Map<const Eigen::Vector3d>(sent.centre_of_mass);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) payload.inertia(r, c) = sent.inertia[r][c];
    }
    if (std::string why = payload_problem(payload); !why.empty()) throw InputError(why);
  } catch (const InputError& e) {
    throw InputError(std::string("payload: ") + e.what());
  }
  Json out;
  out["channel"] = channel;
  out["utime"] = sent.utime;
  out["mass"] = sent.mass;
  out["centre_of_mass"] = vector_json(Eigen::Map<const Eigen::Vector3d>(sent.centre_of_mass));
  out["inertia"] = rows_json(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(&sent.inertia[0][0]));
  publish(o.wire, channel, bytes);
  return out;
}

}  // namespace

Command register_mode(CLI::App& app) {
  auto options = std::make_shared<ModeOptions>();
  CLI::App* command = app.add_subcommand(
      "mode", "Switch the controller's control law (control_mode_t): computed torque, joint or Cartesian impedance, "
              "free drive");
  command
      ->add_option("law", options->law, "computed-torque, joint-impedance, cartesian-impedance or free-drive")
      ->required()
      ->type_name("LAW");
  command
      ->add_option("--robot,--urdf", options->model.urdf,
                   "Robot description (URDF file) the controller drives: the mode is checked against its joints "
                   "and limits")
      ->required()
      ->type_name("FILE");
  command
      ->add_option("--tip", options->model.tip,
                   "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
  CLI::Option* stiffness =
      command
          ->add_option("--stiffness", options->stiffness,
                       "joint-impedance (required): joint stiffness K, N*m/rad (N/m for a prismatic joint), in (0, " +
                           quote(LawBounds::kMaxJointStiffness) + "]; one for every joint or one per joint, root to tip")
          ->type_name("K[,K...]");
  CLI::Option* damping =
      command
          ->add_option("--damping", options->damping,
                       "joint-impedance: joint damping D, N*m*s/rad, >= 0 (default: 2 Z sqrt(K M_ii(q)) from "
                       "--damping-ratio); free-drive: its damping, > 0 (default: D_i = " +
                           quote(LawDefaults::kFreeDriveRate) + "/s * M(q), the whole mass matrix)")
          ->type_name("D[,D...]");
  CLI::Option* ratio = command
                           ->add_option("--damping-ratio", options->damping_ratio,
                                        "joint- and cartesian-impedance: damping ratio Z in [" +
                                            quote(LawBounds::kMinDampingRatio) + ", " +
                                            quote(LawBounds::kMaxDampingRatio) + "], 1 critical (default " +
                                            quote(LawDefaults::kDampingRatio) + ")")
                           ->type_name("Z");
  CLI::Option* translational =
      command
          ->add_option("--translational", options->translational,
                       "cartesian-impedance: translational stiffness along each axis of the stiffness frame, N/m, "
                       "at most " + quote(LawBounds::kMaxTranslationalStiffness) + " (default " +
                           quote(LawDefaults::kTranslationalStiffness) + ")")
          ->type_name("K");
  CLI::Option* rotational = command
                                ->add_option("--rotational", options->rotational,
                                             "cartesian-impedance: rotational stiffness about each axis, N*m/rad, "
                                             "at most " + quote(LawBounds::kMaxRotationalStiffness) + " (default " +
                                                 quote(LawDefaults::kRotationalStiffness) + ")")
                                ->type_name("K");
  CLI::Option* cartesian =
      command
          ->add_option("--cartesian-stiffness", options->cartesian_stiffness,
                       "cartesian-impedance, instead of --translational/--rotational: the 6x6 stiffness in (w, v) "
                       "order, rotational first: 6 numbers (its diagonal) or 36 (row by row; symmetric, positive "
                       "definite)")
          ->type_name("K,...")
          ->excludes(translational)
          ->excludes(rotational);
  CLI::Option* frame =
      command
          ->add_option("--frame", options->frame,
                       "cartesian-impedance: the stiffness frame in the tip frame: origin x,y,z (m, within " +
                           quote(LawBounds::kMaxFrameOffset) + " m) and unit quaternion qw,qx,qy,qz (default: the tip frame)")
          ->type_name("X,Y,Z[,QW,QX,QY,QZ]");
  CLI::Option* posture =
      command
          ->add_option("--posture", options->posture,
                       "cartesian-impedance: a fixed posture the nullspace pulls toward, rad or m per joint, within "
                       "the limits (default: the reference the arm follows)")
          ->type_name("Q,Q,...");
  CLI::Option* nullspace = command
                               ->add_option("--nullspace-stiffness", options->nullspace_stiffness,
                                            "cartesian-impedance: nullspace stiffness, N*m/rad per joint, in [0, " +
                                                quote(LawBounds::kMaxNullspaceStiffness) + "] (default " +
                                                quote(LawDefaults::kNullspaceStiffness) + ")")
                               ->type_name("K");
  add_wire_options(*command, options->wire, "mode", "MODE");
  damping->excludes(ratio);  // explicit damping replaces the ratio; free drive has none

  const std::vector<LawOption> law_options = {
      {stiffness, {Law::kJointImpedance}},
      {damping, {Law::kJointImpedance, Law::kFreeDrive}},
      {ratio, {Law::kJointImpedance, Law::kCartesianImpedance}},
      {translational, {Law::kCartesianImpedance}},
      {rotational, {Law::kCartesianImpedance}},
      {cartesian, {Law::kCartesianImpedance}},
      {frame, {Law::kCartesianImpedance}},
      {posture, {Law::kCartesianImpedance}},
      {nullspace, {Law::kCartesianImpedance}},
  };
  command->footer(
      "Sends one chasles.control_mode_t on PREFIX MODE and prints what was sent:\n"
      "  {\"channel\", \"utime\", \"law\", and the settings the law reads: \"joint_names\", \"joint_stiffness\",\n"
      "   \"joint_damping\", \"damping_ratio\", \"cartesian_stiffness\" (6x6 rows), \"stiffness_frame_position\",\n"
      "   \"stiffness_frame_quaternion\" (normalised), \"quaternion_input_norm\", \"nullspace_posture\",\n"
      "   \"nullspace_stiffness\"}\n"
      "Refused, with nothing sent, exactly as the controller would refuse it: an unknown law, an option the law\n"
      "does not read, a wrong number of values, a non-finite number, a stiffness not positive or over its bound\n"
      "(joint " + quote(LawBounds::kMaxJointStiffness) + ", rotational " + quote(LawBounds::kMaxRotationalStiffness) +
      ", translational " + quote(LawBounds::kMaxTranslationalStiffness) + ", nullspace " +
      quote(LawBounds::kMaxNullspaceStiffness) + "), a Cartesian stiffness not symmetric or not\n"
      "positive definite, a damping ratio outside [" + quote(LawBounds::kMinDampingRatio) + ", " +
      quote(LawBounds::kMaxDampingRatio) + "], a negative damping (free drive: not positive), a frame\n"
      "quaternion whose norm is more than 1e-3 from 1 or a frame origin over " + quote(LawBounds::kMaxFrameOffset) +
      " m from the tip, a posture outside\n"
      "the joint limits.\n"
      "Examples:\n"
      "  chasles mode computed-torque --robot panda.urdf --tip panda_hand\n"
      "  chasles mode joint-impedance --robot panda.urdf --tip panda_hand --stiffness 600,600,600,600,250,150,50\n"
      "  chasles mode cartesian-impedance --robot panda.urdf --tip panda_hand --translational 800 --rotational 40 \\\n"
      "      --frame 0,0,0.1 --posture 0,-0.3,0,-2,0,1.7,0.8\n"
      "  chasles mode free-drive --robot panda.urdf --tip panda_hand --damping 2 \\\n"
      "      --lcm-url 'udpm://239.255.76.67:7667?ttl=0'");
  return {command, [options, law_options] { return run_mode(*options, law_options); }};
}

Command register_payload(CLI::App& app) {
  auto options = std::make_shared<PayloadOptions>();
  CLI::App* command =
      app.add_subcommand("payload", "Tell the controller the load at the arm's tip (payload_t); --mass 0 removes it");
  command->add_option("--mass", options->mass, "The load's mass, kg, >= 0; 0 removes the payload")
      ->required()
      ->type_name("KG");
  command
      ->add_option("--com", options->com, "Its centre of mass in the tip frame, m (default: the tip frame's origin)")
      ->type_name("X,Y,Z");
  command
      ->add_option("--inertia", options->inertia,
                   "Its rotational inertia about its centre of mass, in the tip frame's axes, kg*m^2: the principal "
                   "moments, and the products of inertia if not 0 (default: 0, a point mass)")
      ->type_name("IXX,IYY,IZZ[,IXY,IXZ,IYZ]");
  add_wire_options(*command, options->wire, "payload", "PAYLOAD");
  command->footer(
      "Sends one chasles.payload_t on PREFIX PAYLOAD and prints what was sent:\n"
      "  {\"channel\", \"utime\", \"mass\", \"centre_of_mass\", \"inertia\" (3x3 rows)}\n"
      "The tip frame is that of the controller's --tip link. Refused, with nothing sent, as the controller\n"
      "would refuse it: a non-finite number, a negative mass, an inertia that is not a body's (a negative\n"
      "principal moment, or moments breaking the triangle inequality), --com or --inertia with --mass 0.\n"
      "Examples:\n"
      "  chasles payload --mass 1.2 --com 0,0,0.08\n"
      "  chasles payload --mass 2 --com 0,0,0.1 --inertia 0.01,0.01,0.005\n"
      "  chasles payload --mass 0");
  return {command, [options] { return run_payload(*options); }};
}

}  // namespace chasles::cli
