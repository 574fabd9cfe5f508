#include "gipdyn/kernels/kernel_factory.hpp"


#include "gipdyn/error.hpp"
#include "gipdyn/kernels/composite_kernels.hpp"
#include "gipdyn/kernels/friction_kernel.hpp"
#include "gipdyn/kernels/gip_kernel.hpp"
#include "gipdyn/kernels/parametric_kernel.hpp"
#include "gipdyn/kernels/rbf_kernel.hpp"

namespace gipdyn {

const std::vector<std::string>& kernel_names() {
  static const std::vector<std::string> names{"gip", "gip-friction", "rbf", "gip+rbf", "gip-friction+rbf",
                                               "gip+friction", "gip+friction+rbf", "gip-envelope",
                                               "gip-envelope+friction", "pp", "sp"};
  return names;
}

bool kernel_needs_robot(const std::string& name) { return name == "pp" || name == "sp"; }

bool is_gip_kernel(const std::string& name) { return name == "gip" || name == "gip-friction"; }

GipKernel make_gip_kernel(const std::string& name, const FeatureMap& features, int joint) {
  if (!is_gip_kernel(name)) throw Error("make_gip_kernel: '" + name + "' is not a GIP kernel");
  return GipKernel(features, name == "gip-friction" ? joint : -1);
}

void require_known_kernel(const std::string& name) { require_one_of(name, kernel_names(), "kernel"); }

void require_matching_robot(const RobotPrior& prior, const JointTypes& joints) {
  if (prior.robot && prior.robot->joint_types().str() != joints.str())
    throw Error("robot '" + prior.robot->name() + "' has joints " + prior.robot->joint_types().str() +
                " but the data have " + joints.str() + "; give a robot prior (RobotPrior::robot) with the data's joint types");
}

namespace {

std::unique_ptr<Kernel> make_rbf(const FeatureMap& features, const std::string& prefix = "rbf") {
  std::vector<int> cols;
  std::vector<std::string> labels;
  for (int c = 0; c < features.input_dim(); ++c) {
    cols.push_back(c);
    labels.push_back(features.name(c));
  }
  return std::make_unique<RbfKernel>(cols, labels, prefix);
}

// Structured part plus a local RBF that starts with a tenth of the variance.
std::unique_ptr<Kernel> with_rbf(std::unique_ptr<Kernel> structured, const FeatureMap& features) {
  std::vector<std::unique_ptr<Kernel>> parts;
  parts.push_back(std::move(structured));
  parts.push_back(make_rbf(features));
  return std::make_unique<SumKernel>(std::move(parts), std::vector<double>{0.9, 0.1});
}

// A structured part plus the smooth friction and offset of the joint's own motor
// (90 % / 10 % of the variance at the start), and optionally a local RBF (80 / 10 / 10).
std::unique_ptr<Kernel> with_friction(std::unique_ptr<Kernel> structured, const FeatureMap& features, int joint,
                                      bool rbf) {
  std::vector<std::unique_ptr<Kernel>> parts;
  parts.push_back(std::move(structured));
  parts.push_back(std::make_unique<FrictionKernel>(features.qd(joint)));
  if (!rbf) return std::make_unique<SumKernel>(std::move(parts), std::vector<double>{0.9, 0.1});
  parts.push_back(make_rbf(features));
  return std::make_unique<SumKernel>(std::move(parts), std::vector<double>{0.8, 0.1, 0.1});
}

std::unique_ptr<Kernel> make_envelope(const FeatureMap& features) {
  return std::make_unique<EnvelopeKernel>(std::make_unique<GipKernel>(features), make_rbf(features, "envelope"));
}

}  // namespace

std::unique_ptr<Kernel> make_kernel(const std::string& name, const FeatureMap& features, int joint,
                                    const RobotPrior& prior) {
  if (joint < 0 || joint >= features.num_joints()) throw Error("make_kernel: joint index out of range");
  if (kernel_needs_robot(name)) {
    if (!prior.robot) throw Error("kernel '" + name + "' is model-based and needs the nominal robot (RobotPrior::robot)");
    require_matching_robot(prior, features.joints());
  }
  if (is_gip_kernel(name)) return std::make_unique<GipKernel>(make_gip_kernel(name, features, joint));
  if (name == "rbf") return make_rbf(features);
  if (name == "gip+rbf") return with_rbf(std::make_unique<GipKernel>(features), features);
  if (name == "gip-friction+rbf") return with_rbf(std::make_unique<GipKernel>(features, joint), features);
  if (name == "gip-envelope") return make_envelope(features);
  if (name == "gip-envelope+friction") return with_friction(make_envelope(features), features, joint, false);
  if (name == "gip+friction") return with_friction(std::make_unique<GipKernel>(features), features, joint, false);
  if (name == "gip+friction+rbf") return with_friction(std::make_unique<GipKernel>(features), features, joint, true);
  if (name == "pp") return std::make_unique<ParametricKernel>(prior.robot, joint, prior.friction);
  if (name == "sp") return with_rbf(std::make_unique<ParametricKernel>(prior.robot, joint, prior.friction), features);
  require_known_kernel(name);
  throw Error("make_kernel: kernel '" + name + "' is listed but not built here");
}

}  // namespace gipdyn
