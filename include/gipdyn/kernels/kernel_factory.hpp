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

// Names accepted by make_kernel.
const std::vector<std::string>& kernel_names();
// Whether the kernel needs a RobotPrior with a robot (pp, sp).
bool kernel_needs_robot(const std::string& name);

// Whether the kernel is a GipKernel (gip, gip-friction): such models get the fused prediction path.
bool is_gip_kernel(const std::string& name);
// The GipKernel of joint `joint` for gip or gip-friction (default parameters).
GipKernel make_gip_kernel(const std::string& name, const FeatureMap& features, int joint);

// Throws gipdyn::Error, listing the valid names, unless name is one of them.
void require_known_kernel(const std::string& name);
// Throws gipdyn::Error when the prior has a robot whose joints differ from `joints`.
void require_matching_robot(const RobotPrior& prior, const JointTypes& joints);

// The kernel of joint `joint` (0-based) of a robot with the given feature map:
//   "gip"               GIP kernel
//   "gip-friction"      GIP + viscous and Coulomb friction of the joint's own motor
//   "rbf"               RBF with ARD lengthscales on (q, qd, qdd)
//   "gip+rbf"           GIP + RBF (a structured part that generalises, a local part for the rest)
//   "gip-friction+rbf"  GIP-friction + RBF
//   "gip+friction"      GIP + smooth Coulomb (tanh), viscous and Stribeck friction of the
//                       joint's own motor and a torque offset (FrictionKernel), scales learned
//   "gip+friction+rbf"  the same + RBF
//   "gip-envelope"      GIP x a long-lengthscale RBF envelope (EnvelopeKernel): reverts to the
//                       prior mean far from the training inputs instead of extrapolating a polynomial
//   "gip-envelope+friction"  gip-envelope + the joint's smooth friction and offset (FrictionKernel);
//                       the kernel of the "real" preset
//   "pp"                parametric prior on the rigid-body regressor of prior.robot
//   "sp"                PP + RBF (semiparametric)
// Sums start with 90 % of the output variance in the structured part.
// Throws gipdyn::Error for an unknown name or a missing robot.
std::unique_ptr<Kernel> make_kernel(const std::string& name, const FeatureMap& features, int joint,
                                    const RobotPrior& prior = {});

}  // namespace gipdyn
