#include "gipdyn/kernels/kernel_factory.hpp"

#include <algorithm>

#include "gipdyn/error.hpp"
#include "gipdyn/kernels/gip_kernel.hpp"
#include "gipdyn/kernels/rbf_kernel.hpp"

namespace gipdyn {

const std::vector<std::string>& kernel_names() {
  static const std::vector<std::string> names{"gip", "gip-friction", "rbf"};
  return names;
}

void require_known_kernel(const std::string& name) {
  const auto& names = kernel_names();
  if (std::find(names.begin(), names.end(), name) != names.end()) return;
  std::string valid;
  for (const auto& n : names) valid += (valid.empty() ? "" : ", ") + n;
  throw Error("unknown kernel '" + name + "'; choose one of: " + valid);
}

std::unique_ptr<Kernel> make_kernel(const std::string& name, const FeatureMap& features, int joint) {
  if (joint < 0 || joint >= features.num_joints()) throw Error("make_kernel: joint index out of range");
  if (name == "gip") return std::make_unique<GipKernel>(features);
  if (name == "gip-friction") return std::make_unique<GipKernel>(features, joint);
  if (name == "rbf") {
    std::vector<int> cols;
    std::vector<std::string> labels;
    for (int c = 0; c < features.input_dim(); ++c) {
      cols.push_back(c);
      labels.push_back(features.name(c));
    }
    return std::make_unique<RbfKernel>(cols, labels);
  }
  require_known_kernel(name);
  throw Error("make_kernel: kernel '" + name + "' is listed but not built here");
}

}  // namespace gipdyn
