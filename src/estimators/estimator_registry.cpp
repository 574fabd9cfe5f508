#include "gipdyn/estimators/estimator_registry.hpp"

#include <algorithm>

#include "gipdyn/error.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"

namespace gipdyn {

const std::vector<std::string>& estimator_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = kernel_names();
    n.push_back("lip");
    n.push_back("lip+friction");
    n.push_back("fe");
    n.push_back("chain");
    n.push_back("nn");
    return n;
  }();
  return names;
}

void require_known_estimator(const std::string& name) { require_one_of(name, estimator_names(), "estimator"); }

EstimatorFamily estimator_family(const std::string& name) {
  require_known_estimator(name);
  if (name == "lip" || name == "lip+friction") return EstimatorFamily::Lagrangian;
  if (name == "fe" || name == "chain") return EstimatorFamily::Fisherian;
  if (name == "nn") return EstimatorFamily::NeuralNetwork;
  return EstimatorFamily::Gp;
}

bool is_gp_estimator(const std::string& name) {
  const auto& k = kernel_names();
  return std::find(k.begin(), k.end(), name) != k.end();
}

bool is_kernel_estimator(const std::string& name) {
  return is_gp_estimator(name) || name == "lip" || name == "lip+friction";
}

bool estimator_needs_robot(const std::string& name) { return name == "fe" || kernel_needs_robot(name); }

}  // namespace gipdyn
