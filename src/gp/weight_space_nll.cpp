#include "gipdyn/gp/weight_space_nll.hpp"

#include <cmath>

#include "gipdyn/error.hpp"

namespace gipdyn {

WeightSpaceNll::WeightSpaceNll(Eigen::MatrixXd Phi, Eigen::VectorXd y) : Phi_(std::move(Phi)), y_(std::move(y)) {
  if (Phi_.rows() != y_.size()) throw Error("weight-space NLL: the features and the targets have different rows");
  gram_.noalias() = Phi_.transpose() * Phi_;
  Phi_y_.noalias() = Phi_.transpose() * y_;
}

NllEvaluation WeightSpaceNll::evaluate(const Eigen::VectorXd& log_variances, double log_noise_variance,
                                       bool with_gradient) const {
  NllEvaluation out;
  const Eigen::Index r = Phi_.cols(), n = Phi_.rows();
  if (log_variances.size() != r) throw Error("weight-space NLL: one log-variance per feature expected");
  const Eigen::ArrayXd root_s = (0.5 * log_variances.array()).exp();
  const double noise = std::exp(log_noise_variance);

  // A = B G B + sigma^2 I with B = diag(s)^1/2.
  Eigen::MatrixXd A = root_s.matrix().asDiagonal() * gram_ * root_s.matrix().asDiagonal();
  A.diagonal().array() += noise;
  const Eigen::LLT<Eigen::MatrixXd> llt(A);
  if (llt.info() != Eigen::Success || !A.allFinite()) {
    out.message = "the weight-space matrix Psi^T Psi + noise I is not positive definite at these hyperparameters";
    return out;
  }
  const Eigen::VectorXd m = llt.solve((root_s * Phi_y_.array()).matrix());
  const Eigen::VectorXd residual = y_ - Phi_ * (root_s * m.array()).matrix();
  const double rss = residual.squaredNorm();
  const double log_det_A = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  out.nll = gaussian_nll((rss + noise * m.squaredNorm()) / noise,
                         static_cast<double>(n - r) * log_noise_variance + log_det_A, n);
  if (!std::isfinite(out.nll)) {
    out.message = "marginal likelihood is not finite at these hyperparameters";
    return out;
  }
  out.status = NllEvaluation::Status::Ok;
  if (!with_gradient) return out;

  // alpha = K^-1 y = residual / sigma^2; Psi^T K^-1 Psi = I - sigma^2 A^-1.
  const Eigen::MatrixXd A_inv = llt.solve(Eigen::MatrixXd::Identity(r, r));
  const Eigen::ArrayXd psi_alpha = root_s * (Phi_.transpose() * residual).array() / noise;
  out.gradient.resize(r + 1);
  // d/dlog s_k: 1/2 (psi_k^T K^-1 psi_k - (psi_k^T alpha)^2).
  out.gradient.head(r) = 0.5 * ((1.0 - noise * A_inv.diagonal().array()) - psi_alpha.square()).matrix();
  // d/dlog sigma^2: 1/2 sigma^2 (tr K^-1 - alpha^T alpha), tr K^-1 = (N - r) / sigma^2 + tr A^-1.
  out.gradient(r) = 0.5 * (static_cast<double>(n - r) + noise * A_inv.trace() - rss / noise);
  return out;
}

}  // namespace gipdyn
