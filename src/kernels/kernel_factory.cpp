#include "gipdyn/kernels/kernel_factory.hpp"

#include "gipdyn/error.hpp"
#include "gipdyn/kernels/composite_kernels.hpp"
#include "gipdyn/kernels/friction_kernel.hpp"
#include "gipdyn/kernels/gip_kernel.hpp"
#include "gipdyn/kernels/parametric_kernel.hpp"
#include "gipdyn/kernels/rbf_kernel.hpp"

namespace gipdyn {

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

std::vector<KernelSpec> make_table() {
  using F = const FeatureMap&;
  using P = const RobotPrior&;
  std::vector<KernelSpec> t;
  auto row = [&t](const char* name, const char* help) -> KernelSpec& {
    t.push_back(KernelSpec{});
    t.back().name = name;
    t.back().help = help;
    return t.back();
  };
  KernelSpec* k = &row("gip", "GIP kernel, polynomial in the rigid-body dynamics' own functions of q, qd, qdd: the default, for "
                       "simulated and clean logs");
  k->gip_kernel = k->rigid_body_terms = k->default_kernel = true;
  k->build = [](F f, int, P) -> std::unique_ptr<Kernel> { return std::make_unique<GipKernel>(f); };
  k = &row("gip-friction", "GIP + viscous and Coulomb friction of the joint's own motor");
  k->gip_kernel = k->rigid_body_terms = true;
  k->build = [](F f, int j, P) -> std::unique_ptr<Kernel> { return std::make_unique<GipKernel>(f, j); };
  k = &row("rbf", "RBF with ARD lengthscales on (q, qd, qdd): no structure, the baseline a model must beat");
  k->build = [](F f, int, P) { return make_rbf(f); };
  k = &row("gip+rbf", "GIP + RBF: a structured part that generalises, a local part for what it misses");
  k->build = [](F f, int, P) { return with_rbf(std::make_unique<GipKernel>(f), f); };
  k = &row("gip-friction+rbf", "gip-friction + RBF");
  k->build = [](F f, int j, P) { return with_rbf(std::make_unique<GipKernel>(f, j), f); };
  k = &row("gip+friction",
           "GIP + smooth Coulomb (tanh), viscous and Stribeck friction of the joint's own motor and a torque offset");
  k->rigid_body_terms = true;
  k->build = [](F f, int j, P) { return with_friction(std::make_unique<GipKernel>(f), f, j, false); };
  k = &row("gip+friction+rbf", "gip+friction + RBF");
  k->build = [](F f, int j, P) { return with_friction(std::make_unique<GipKernel>(f), f, j, true); };
  k = &row("gip-envelope",
           "GIP x a long-lengthscale RBF envelope: reverts to the prior mean far from the training inputs");
  k->build = [](F f, int, P) { return make_envelope(f); };
  k = &row("gip-envelope+friction", "gip-envelope + the joint's smooth friction and offset: for real robots' logs (the real preset)");
  k->build = [](F f, int j, P) { return with_friction(make_envelope(f), f, j, false); };
  k = &row("pp", "parametric prior on the nominal robot's rigid-body regressor: when its URDF is close, short logs");
  k->needs_robot = k->rigid_body_terms = k->finite_features = true;
  k->build = [](F, int j, P p) -> std::unique_ptr<Kernel> {
    return std::make_unique<ParametricKernel>(p.robot, j, p.friction);
  };
  k = &row("sp", "pp + RBF (semiparametric): a nominal robot whose model misses effects the log shows");
  k->needs_robot = true;
  k->build = [](F f, int j, P p) { return with_rbf(std::make_unique<ParametricKernel>(p.robot, j, p.friction), f); };
  return t;
}

}  // namespace

const std::vector<KernelSpec>& kernel_table() {
  static const std::vector<KernelSpec> table = make_table();
  return table;
}

const std::vector<std::string>& kernel_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const KernelSpec& k : kernel_table()) n.push_back(k.name);
    return n;
  }();
  return names;
}

const std::string& default_kernel_name() {
  for (const KernelSpec& k : kernel_table())
    if (k.default_kernel) return k.name;
  throw Error("kernel table: no row is the default kernel");
}

const KernelSpec& kernel_spec(const std::string& name) {
  for (const KernelSpec& k : kernel_table())
    if (k.name == name) return k;
  require_one_of(name, kernel_names(), "kernel");  // throws, listing the names
  throw Error("kernel '" + name + "' is not in the kernel table");
}

void require_known_kernel(const std::string& name) { kernel_spec(name); }

bool kernel_needs_robot(const std::string& name) { return kernel_spec(name).needs_robot; }

bool is_gip_kernel(const std::string& name) { return kernel_spec(name).gip_kernel; }

GipKernel make_gip_kernel(const std::string& name, const FeatureMap& features, int joint) {
  const KernelSpec& spec = kernel_spec(name);
  if (!spec.gip_kernel) throw Error("make_gip_kernel: '" + name + "' is not a GIP kernel");
  std::unique_ptr<Kernel> k = spec.build(features, joint, RobotPrior{});
  return *static_cast<GipKernel*>(k.get());
}

void require_matching_robot(const RobotPrior& prior, const JointTypes& joints) {
  if (prior.robot && prior.robot->joint_types().str() != joints.str())
    throw Error("robot '" + prior.robot->name() + "' has joints " + prior.robot->joint_types().str() +
                " but the data have " + joints.str() + "; give a robot prior (RobotPrior::robot) with the data's joint types");
}

std::unique_ptr<Kernel> make_kernel(const std::string& name, const FeatureMap& features, int joint,
                                    const RobotPrior& prior) {
  const KernelSpec& spec = kernel_spec(name);
  if (joint < 0 || joint >= features.num_joints()) throw Error("make_kernel: joint index out of range");
  if (spec.needs_robot) {
    if (!prior.robot) throw Error("kernel '" + name + "' is model-based and needs the nominal robot (RobotPrior::robot)");
    require_matching_robot(prior, features.joints());
  }
  return spec.build(features, joint, prior);
}

}  // namespace gipdyn
