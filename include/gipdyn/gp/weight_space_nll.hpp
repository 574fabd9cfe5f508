#pragma once
// The exact GP marginal likelihood for kernels that are a finite feature
// expansion with one variance per feature,
//   k(z, z') = phi(z) diag(s) phi(z')^T,  s = exp(log-params)   (the PP kernel),
// computed in weight space: with Psi = Phi diag(s)^1/2 and A = Psi^T Psi + sigma^2 I
// (r x r for r features),
//   y^T K^-1 y = (|y - Psi m|^2 + sigma^2 |m|^2) / sigma^2,  m = A^-1 Psi^T y,
//   log|K|     = (N - r) log sigma^2 + log|A|,
// so that one evaluation costs O(N r + r^3) instead of the O(N^3) of
// evaluate_nll, whose value and gradient it equals up to rounding. Both terms of
// the quadratic form are sums of squares: nothing cancels when the noise is small.
#include <Eigen/Dense>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/exact_gp.hpp"

namespace gipdyn {

class WeightSpaceNll {
 public:
  // Phi: N x r features of the training rows; y: the N targets.
  WeightSpaceNll(Eigen::MatrixXd Phi, Eigen::VectorXd y);

  // NLL and (optionally) its gradient w.r.t. [log s (r), log noise variance],
  // the order of evaluate_nll. NonFinite when A is not positive definite.
  NllEvaluation evaluate(const Eigen::VectorXd& log_variances, double log_noise_variance,
                         bool with_gradient = true) const;

  Eigen::Index features() const { return Phi_.cols(); }

 private:
  Eigen::MatrixXd Phi_, gram_;  // Phi and Phi^T Phi (computed once)
  Eigen::VectorXd y_, Phi_y_;   // y and Phi^T y
};

}  // namespace gipdyn
