// Robots from the wild: every serial chain of the 69 URDFs of example-robot-data 6.0.0 (fetched by
// tools/robot_corpus.sh into $CHASLES_ROBOT_CORPUS) — a leaf of the tree with ≥ 2 movable joints
// and no floating, planar or mimic joint on the way there, 461 chains in all. Each loads, or is
// refused because one of its bodies is clearly not physical; each loaded one runs its kinematics
// and dynamics, and forward dynamics either inverts inverse dynamics or is refused with a reason.
#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"

namespace chasles {
namespace {

namespace fs = std::filesystem;

struct Chain {
  std::string file, tip;
};

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The chains of one file, by the definition above (the one the issue counted with).
std::vector<Chain> chains_of(const fs::path& path) {
  const std::string xml = read(path);
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
  if (!model) {
    // ur3.urdf is a robot with no name and no link: nothing to load, nothing to count.
    if (xml.find("<link") != std::string::npos) throw std::runtime_error("urdfdom cannot parse " + path.string());
    return {};
  }
  std::vector<Chain> chains;
  for (const auto& [name, link] : model->links_) {
    if (!link->child_joints.empty()) continue;
    int movable = 0;
    bool serial = true;
    for (urdf::LinkConstSharedPtr l = link; l->parent_joint; l = model->getLink(l->parent_joint->parent_link_name)) {
      const auto& joint = l->parent_joint;
      serial = serial && joint->type != urdf::Joint::FLOATING && joint->type != urdf::Joint::PLANAR && !joint->mimic;
      movable += joint->type == urdf::Joint::REVOLUTE || joint->type == urdf::Joint::CONTINUOUS ||
                 joint->type == urdf::Joint::PRISMATIC;
    }
    if (serial && movable >= 2) chains.push_back({path.string(), name});
  }
  return chains;
}

std::vector<Chain> corpus_chains() {
  const char* dir = std::getenv("CHASLES_ROBOT_CORPUS");
  if (!dir || !fs::is_directory(dir)) {
    throw std::runtime_error("CHASLES_ROBOT_CORPUS does not name a directory: run tools/robot_corpus.sh DIR");
  }
  std::vector<fs::path> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.path().extension() == ".urdf") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  if (files.size() != 69) throw std::runtime_error("expected the 69 URDFs of example-robot-data 6.0.0");
  std::vector<Chain> chains;
  for (const auto& file : files) {
    for (Chain& chain : chains_of(file)) chains.push_back(std::move(chain));
  }
  return chains;
}

// The bodies that are clearly not physical, by file: each principal moment set misses a triangle
// inequality or non-negativity by 3 % to 33 % of the largest moment, far beyond any rounding
// (tests/data/README.md lists the values).
const std::map<std::string, std::set<std::string>> kUnphysicalBodies = {
    {"romeo_laas_small.urdf", {"LHipPitch_joint", "RHipPitch_joint", "LElbowYaw_joint"}},
    {"romeo_small.urdf", {"RShoulderYaw"}},
};

TEST(RobotCorpus, EveryChainLoadsUnlessABodyIsClearlyNotPhysical) {
  const std::vector<Chain> chains = corpus_chains();
  ASSERT_EQ(chains.size(), 461u);
  int loaded = 0, refused = 0;
  std::string singular;
  size_t warnings = 0;
  for (const Chain& chain : chains) {
    SCOPED_TRACE(chain.file + " --tip " + chain.tip);
    UrdfOptions options;
    options.tip_link = chain.tip;
    try {
      const RobotModel model = load_urdf_file(chain.file, options);
      ++loaded;
      warnings += model.warnings().size();
      Data data(model);
      Eigen::VectorXd q(model.dof());
      for (int i = 0; i < model.dof(); ++i) q(i) = 0.5 * (model.joint(i).limits.lower + model.joint(i).limits.upper);
      const Eigen::VectorXd qd = Eigen::VectorXd::LinSpaced(model.dof(), -0.5, 0.5);
      const Eigen::VectorXd qdd = Eigen::VectorXd::LinSpaced(model.dof(), 1.0, -1.0);
      ASSERT_TRUE(forward_kinematics(model, data, q).matrix().allFinite());
      ASSERT_TRUE(body_jacobian(model, data, q).allFinite());
      const Eigen::VectorXd tau = inverse_dynamics(model, data, q, qd, qdd);
      ASSERT_TRUE(tau.allFinite());
      const std::string defect = mass_matrix_defect(model, data, q);
      if (defect.empty()) {
        // FD ∘ ID = id, to the conditioning of M.
        const Eigen::VectorXd qdd_back = forward_dynamics(model, data, q, qd, tau);
        const double condition = 1.0 / data.M_llt.rcond();
        EXPECT_LE((qdd_back - qdd).norm(), 1e-12 * condition * (1.0 + qdd.norm()));
      } else {
        singular += " " + fs::path(chain.file).filename().string() + ":" + chain.tip;
        EXPECT_NE(defect.find("moves no inertia"), std::string::npos) << defect;
        EXPECT_THROW(forward_dynamics(model, data, q, qd, tau), DynamicsError);
      }
    } catch (const ModelError& e) {
      ++refused;
      const std::string what = e.what();
      const std::string file = fs::path(chain.file).filename().string();
      bool named = false;
      if (kUnphysicalBodies.count(file)) {
        for (const auto& joint : kUnphysicalBodies.at(file)) {
          named = named || what.find("the body moved by joint '" + joint + "'") != std::string::npos;
        }
      }
      EXPECT_TRUE(named && what.find("not physical") != std::string::npos) << what;
    }
  }
  std::cout << "[ corpus ] " << chains.size() << " chains: " << loaded << " load, " << refused << " refused; "
            << warnings << " warnings in all; M singular at mid-range:" << singular << std::endl;
  EXPECT_EQ(refused, 29);  // every chain through one of those four bodies, and no other
  EXPECT_EQ(loaded + refused, 461);
}

}  // namespace
}  // namespace chasles
