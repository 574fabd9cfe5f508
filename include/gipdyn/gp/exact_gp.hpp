#pragma once
// Exact GP regression for one output (docs/method.md section 3).
//
//   K = k(X, X) + sigma_n^2 I (+ jitter only if Cholesky fails), alpha = K^{-1} y
//   mean(x*) = k(x*, X) alpha,  var(x*) = k(x*, x*) - k(x*, X) K^{-1} k(X, x*)
//   NLL = 1/2 y^T alpha + sum_i log L_ii + N/2 log(2 pi)
//   dNLL/dtheta = -1/2 tr((alpha alpha^T - K^{-1}) dK/dtheta)
//
// The hyperparameter vector of a GP is [kernel log-parameters..., log sigma_n^2].
#include <Eigen/Dense>
#include <memory>
#include <string>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/mean_function.hpp"
#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

// Mutable buffers for NLL evaluations and fits (one per thread). The N x N
// matrix K is reused across calls, so an optimiser allocates it once.
struct GpWorkspace {
  Eigen::MatrixXd K;
  Eigen::VectorXd alpha;
  KernelScratch scratch;
};

struct NllEvaluation {
  enum class Status {
    Ok,
    NotPositiveDefinite,  // Cholesky failed even with the largest jitter
    NonFinite,            // the NLL or the mean's coefficients are not finite
    InversionFailed,      // LAPACK potri failed (gradient only)
  };
  Status status = Status::NonFinite;
  bool ok() const { return status == Status::Ok; }
  double nll = 0.0;
  Eigen::VectorXd gradient;  // w.r.t. [kernel log-params, log noise variance]
  double jitter = 0.0;
  std::string message;
};

// The factorisation's result behind a value-only evaluation (a final fit):
// status, jitter and message; NonFinite stays NonFinite, other failures are
// NotPositiveDefinite.
CholeskyResult fit_result(const NllEvaluation& e);

// The Gaussian NLL from its parts, for y ~ N(0, K) with N rows:
// 1/2 y^T K^-1 y + 1/2 log det K + N/2 log(2 pi).
double gaussian_nll(double y_dot_alpha, double log_det, Eigen::Index rows);

// Negative log marginal likelihood of y and (optionally) its gradient.
NllEvaluation evaluate_nll(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, bool with_gradient, GpWorkspace& ws,
                           const JitterPolicy& jitter = {});

// The same for a GP with prior mean m(x) = h(x)^T beta on the raw inputs X,
// with beta profiled out: for the given kernel and noise, beta is the
// generalised least-squares estimate (H^T K^-1 H)^-1 H^T K^-1 y, which
// minimises the NLL over beta. Since dNLL/dbeta = -H^T alpha = 0 there, the
// gradient w.r.t. [kernel log-params, log noise variance] is that of the
// zero-mean NLL of y - H beta. The optimiser then sees only the log-parameters.
// beta (optional) receives the coefficients.
NllEvaluation evaluate_profiled_nll(const Kernel& kernel, double log_noise_variance, const MeanFunction& mean,
                                    const Eigen::MatrixXd& X, const Eigen::MatrixXd& Z, const Eigen::VectorXd& y,
                                    bool with_gradient, GpWorkspace& ws, Eigen::VectorXd* beta = nullptr,
                                    const JitterPolicy& jitter = {});

// A GP conditioned on training data. The training features Z are owned by the
// caller (an inverse dynamics model shares them among its joints).
class GpRegressor {
 public:
  GpRegressor() = default;
  GpRegressor(std::unique_ptr<Kernel> kernel, double log_noise_variance);
  GpRegressor(const GpRegressor& other);
  GpRegressor& operator=(const GpRegressor& other);
  GpRegressor(GpRegressor&&) = default;
  GpRegressor& operator=(GpRegressor&&) = default;

  // Computes alpha (and keeps the Cholesky factor if keep_factor, needed for
  // variances). Returns the factorisation status; on failure the GP is unusable.
  CholeskyResult fit(const Eigen::MatrixXd& Z, const Eigen::VectorXd& y, bool keep_factor, GpWorkspace& ws,
                     const JitterPolicy& jitter = {});
  // Restores a fitted state from stored alpha (the factor is recomputed on demand).
  void set_state(const Eigen::VectorXd& alpha, double jitter, double nll);
  // A sparse GP (gp/sparse_gp.hpp), conditioned through its inducing rows Zm,
  // which then take the place of Z everywhere: alpha, the factor of Kmm (the
  // jitter includes its eps) and that of A, which only the training data can
  // give. Its variance adds |A^-1/2 k*|^2; add_rows_sparse adds rows online.
  void set_sparse_state(const Eigen::VectorXd& alpha, double jitter, double objective,
                        Eigen::MatrixXd inducing_factor, Eigen::MatrixXd posterior_factor);
  bool is_sparse() const { return La_.size() > 0; }
  const Eigen::MatrixXd& posterior_factor() const { return La_; }
  // Recomputes the Cholesky factor from Z for predictive variances (for a sparse
  // GP, that of Kmm from its inducing rows).
  CholeskyResult compute_factor(const Eigen::MatrixXd& Z, GpWorkspace& ws);
  // The targets the GP was fitted to (N-vector): kept since fit() or update(),
  // else K alpha from the factor.
  Eigen::VectorXd fitted_targets() const;
  // The diagonal of (K + noise I)^-1 (the jitter included) from the factor
  // (needs has_factor(); an exact GP): with alpha, every row's leave-one-out
  // prediction, y_i - alpha_i / d_i with variance 1 / d_i. O(N^3 / 3).
  Eigen::VectorXd inverse_diagonal() const;
  // Online learning with the hyperparameters fixed (needs has_factor()): drops
  // the `drop` oldest rows of the factor (one rank-1 update each, O(N^2)),
  // appends the last `added` rows of Z (a bordered factor, O(N^2 added)) and
  // solves alpha for y. Z and y are the new training set: the kept rows in
  // order, then the added ones. Works in the factor's own buffer; on a status
  // other than Ok the factor is dropped and the GP must not be used.
  CholeskyResult update(Eigen::Index drop, const Eigen::MatrixXd& Z, Eigen::Index added, const Eigen::VectorXd& y);
  // The sparse GP's online learning, inducing rows Zm and hyperparameters
  // fixed: conditions on the new rows (Zadded, yadded) as well as on every
  // row before, A += Kmn' Kn'm / s (one rank-1 update of A's factor per row)
  // and alpha = A^-1 (Kmn y + Kmn' y') / s. O(M^2) per row, whatever the number
  // of rows already in; rows cannot be dropped, since the GP does not keep them.
  CholeskyResult add_rows_sparse(const Eigen::MatrixXd& Zm, const Eigen::MatrixXd& Zadded,
                                 const Eigen::VectorXd& yadded);

  void predict_mean(const Eigen::MatrixXd& Zstar, const Eigen::MatrixXd& Z, Eigen::VectorXd& mean) const;
  // Latent (noise-free) predictive variance; requires has_factor().
  void predict_variance(const Eigen::MatrixXd& Zstar, const Eigen::MatrixXd& Z, Eigen::VectorXd& var) const;
  // One query: k(z, Z) into krow (size N, preallocated) and the mean; no allocation
  // for kernels that implement Kernel::row without it.
  double predict_mean_one(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> krow,
                          KernelScratch& scratch) const;
  // Variance for the krow computed by predict_mean_one with the same scratch (v
  // is an N-vector buffer).
  double predict_variance_one(const double* z, int feature_dim, const Eigen::Ref<const Eigen::VectorXd>& krow,
                              Eigen::Ref<Eigen::VectorXd> v, KernelScratch& scratch) const;

  const Kernel& kernel() const { return *kernel_; }
  Kernel& kernel() { return *kernel_; }
  double log_noise_variance() const { return log_noise_; }
  const Eigen::VectorXd& alpha() const { return alpha_; }
  bool has_factor() const { return L_.size() > 0; }
  double jitter() const { return jitter_; }
  double nll() const { return nll_; }

 private:
  std::unique_ptr<Kernel> kernel_;
  double log_noise_ = 0.0;
  Eigen::VectorXd alpha_;
  // The targets alpha was solved for: kept from fit() and update(), so that a
  // stream of updates does not lose precision recovering them as K alpha
  // (empty after set_state: a loaded GP recovers them once from the factor).
  Eigen::VectorXd y_;
  Eigen::MatrixXd L_;  // lower Cholesky factor of K (empty until needed)
  Eigen::MatrixXd La_;  // sparse GPs only: lower Cholesky factor of A
  // Sparse GPs after add_rows_sparse: Kmn y, kept so that a stream of added
  // rows does not lose precision recovering it from A's factor and alpha.
  Eigen::VectorXd sparse_b_;
  double jitter_ = 0.0;
  double nll_ = 0.0;
};

}  // namespace gipdyn
