#pragma once
// Log-normal priors on the hyperparameters for MAP training: every
// log-parameter theta_k (kernel parameters and the noise variance) gets an
// independent N(mu_k, width^2) prior centred on its data-driven start, so a few
// samples cannot push a polynomial factor's weight to an extreme (e^(2 width)
// away from the start costs 2 nats per parameter).
#include <Eigen/Dense>
#include <string>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

struct HyperparameterPrior {
  bool enabled = false;  // off: maximum likelihood, as the paper
  double width = 2.0;    // standard deviation of each log-parameter
  void validate() const;  // throws gipdyn::Error
};

// "none" (maximum likelihood) or "lognormal" (MAP) with the given width.
HyperparameterPrior parse_hyperparameter_prior(const std::string& name, double width);
std::string to_string(const HyperparameterPrior& prior);  // "none" | "lognormal"

// -log p(theta) up to a constant: sum_k (theta_k - mu_k)^2 / (2 width^2);
// its gradient is added to *grad when grad is not null.
double prior_penalty(const Eigen::VectorXd& theta, const Eigen::VectorXd& mu, double width, Eigen::VectorXd* grad);

}  // namespace gipdyn
