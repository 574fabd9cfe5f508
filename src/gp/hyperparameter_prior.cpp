#include "gipdyn/gp/hyperparameter_prior.hpp"

#include "gipdyn/error.hpp"

namespace gipdyn {

void HyperparameterPrior::validate() const {
  if (!(width > 0.0)) throw Error("HyperparameterPrior::width must be > 0 (the standard deviation of each log-hyperparameter)");
}

double prior_penalty(const Eigen::VectorXd& theta, const Eigen::VectorXd& mu, double width, Eigen::VectorXd* grad) {
  if (theta.size() != mu.size()) throw Error("prior_penalty: parameter and mean sizes differ");
  const Eigen::VectorXd d = theta - mu;
  const double inv = 1.0 / (width * width);
  if (grad) *grad += inv * d;
  return 0.5 * inv * d.squaredNorm();
}

HyperparameterPrior parse_hyperparameter_prior(const std::string& name, double width) {
  if (name != "none" && name != "lognormal")
    throw Error("GpOptions::prior '" + name + "' is unknown; choose none or lognormal");
  HyperparameterPrior p;
  p.enabled = name == "lognormal";
  p.width = width;
  return p;
}

std::string to_string(const HyperparameterPrior& prior) { return prior.enabled ? "lognormal" : "none"; }

}  // namespace gipdyn
