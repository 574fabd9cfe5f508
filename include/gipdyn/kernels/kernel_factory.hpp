#pragma once
// Kernels by name, as the CLI, the model file and the Python module select them.
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/features.hpp"
#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

// Names accepted by make_kernel.
const std::vector<std::string>& kernel_names();

// Throws gipdyn::Error, listing the valid names, unless name is one of them.
void require_known_kernel(const std::string& name);

// The kernel of joint `joint` (0-based) of a robot with the given feature map:
//   "gip"           GIP kernel
//   "gip-friction"  GIP + viscous and Coulomb friction of the joint's own motor
//   "rbf"           RBF with ARD lengthscales on (q, qd, qdd)
// Throws gipdyn::Error for an unknown name, listing the valid ones.
std::unique_ptr<Kernel> make_kernel(const std::string& name, const FeatureMap& features, int joint);

}  // namespace gipdyn
