#pragma once
// Kernels by name, as the CLI, the model file and the Python module select them.
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/features.hpp"
#include "gipdyn/kernels/gip_kernel.hpp"
#include "gipdyn/kernels/kernel.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

// The nominal robot model that model-based kernels (pp, sp) are built on.
struct RobotPrior {
  std::shared_ptr<const RobotModel> robot;
  bool friction = false;  // add viscous and Coulomb friction parameters to the regressor
};

// One row of the kernel table: the only place a kernel's name is spelled.
struct KernelSpec {
  std::string name;
  std::string help;            // one line: what the kernel is
  bool needs_robot = false;    // built on RobotPrior::robot (the model-based pp, sp)
  bool gip_kernel = false;     // a GipKernel: the fused prediction path
  bool rigid_body_terms = false;  // gravity, inertia and Coriolis torques out of a fitted model (physics.hpp)
  bool finite_features = false;   // a finite feature expansion: the NLL in weight space (gp/weight_space_nll.hpp)
  bool default_kernel = false;    // TrainOptions::kernel's default, and the estimator train fits by default
  // The kernel of joint `joint` (0-based); prior.robot is set where needs_robot.
  std::unique_ptr<Kernel> (*build)(const FeatureMap& features, int joint, const RobotPrior& prior) = nullptr;
};

// Every kernel make_kernel builds, in the order front ends list them. Sums
// start with 90 % of the output variance in the structured part.
const std::vector<KernelSpec>& kernel_table();
// The row of `name`; throws gipdyn::Error listing the valid names otherwise.
const KernelSpec& kernel_spec(const std::string& name);

// The row marked default_kernel.
const std::string& default_kernel_name();
// The table's names, in order.
const std::vector<std::string>& kernel_names();
// Readers of the table's columns, for a valid name (else they throw as kernel_spec).
bool kernel_needs_robot(const std::string& name);
bool is_gip_kernel(const std::string& name);
// The GipKernel of joint `joint` for a kernel whose gip_kernel column is set (default parameters).
GipKernel make_gip_kernel(const std::string& name, const FeatureMap& features, int joint);

// Throws gipdyn::Error, listing the valid names, unless name is one of them.
void require_known_kernel(const std::string& name);
// Throws gipdyn::Error when the prior has a robot whose joints differ from `joints`.
void require_matching_robot(const RobotPrior& prior, const JointTypes& joints);

// The kernel `name` of joint `joint` (0-based) of a robot with the given
// feature map. Throws gipdyn::Error for an unknown name, a joint out of range
// or a missing robot.
std::unique_ptr<Kernel> make_kernel(const std::string& name, const FeatureMap& features, int joint,
                                    const RobotPrior& prior = {});

}  // namespace gipdyn
