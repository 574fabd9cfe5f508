#include "gipdyn/gp/exact_gp.hpp"

#include <cmath>

#include "gipdyn/error.hpp"

namespace gipdyn {
namespace {

// L L^T + x x^T -> L' L'^T in place (Givens rotations, O(n^2)); x is consumed.
void rank_one_update(Eigen::Ref<Eigen::MatrixXd> L, Eigen::Ref<Eigen::VectorXd> x) {
  const Eigen::Index n = L.rows();
  for (Eigen::Index k = 0; k < n; ++k) {
    const double r = std::hypot(L(k, k), x(k)), cos = r / L(k, k), sin = x(k) / L(k, k);
    L(k, k) = r;
    const Eigen::Index rest = n - k - 1;
    if (rest == 0) break;
    L.col(k).tail(rest) = (L.col(k).tail(rest) + sin * x.tail(rest)) / cos;
    x.tail(rest) = cos * x.tail(rest) - sin * L.col(k).tail(rest);
  }
}

void build_covariance(const Kernel& kernel, double noise_variance, const Eigen::MatrixXd& Z, Eigen::MatrixXd& K,
                      KernelScratch& scratch) {
  K.resize(Z.rows(), Z.rows());
  kernel.gram_lower(Z, K, scratch);
  K.diagonal().array() += noise_variance;
}

// ws.K = Cholesky factor of k(Z, Z) + diag_add I (with jitter if needed).
CholeskyResult factorize_covariance(const Kernel& kernel, double diag_add, const Eigen::MatrixXd& Z, GpWorkspace& ws,
                                    const JitterPolicy& jitter) {
  build_covariance(kernel, diag_add, Z, ws.K, ws.scratch);
  return cholesky_with_jitter(
      ws.K, [&](Eigen::MatrixXd& K) { build_covariance(kernel, diag_add, Z, K, ws.scratch); }, jitter);
}

// alpha = K^{-1} y from the factor L; returns the NLL.
double solve_and_nll(const Eigen::MatrixXd& L, const Eigen::VectorXd& y, Eigen::VectorXd& alpha) {
  alpha = y;
  cholesky_solve(L, alpha);
  return gaussian_nll(y.dot(alpha), 2.0 * L.diagonal().array().log().sum(), y.size());
}

}  // namespace

namespace {

// NLL (and gradient) of y given ws.K = the Cholesky factor of the covariance.
// Overwrites ws.K with K^{-1} when the gradient is asked for.
void nll_from_factor(const Kernel& kernel, double noise, const Eigen::MatrixXd& Z, const Eigen::VectorXd& y,
                     bool with_gradient, GpWorkspace& ws, NllEvaluation& out) {
  out.nll = solve_and_nll(ws.K, y, ws.alpha);
  if (!std::isfinite(out.nll)) {
    out.message = "marginal likelihood is not finite at these hyperparameters";
    return;
  }
  out.status = NllEvaluation::Status::Ok;
  if (!with_gradient) return;

  if (!cholesky_inverse_in_place(ws.K)) {
    out.status = NllEvaluation::Status::InversionFailed;
    out.message = "could not invert the kernel matrix (LAPACK potri failed)";
    return;
  }
  const int P = kernel.num_params();
  out.gradient = Eigen::VectorXd::Zero(P + 1);
  kernel.contract_nll(Z, ws.alpha, ws.K, out.gradient.head(P), ws.scratch);
  out.gradient.head(P) *= -0.5;
  // dK/dlog(sigma^2) = sigma^2 I: -1/2 sigma^2 (alpha^T alpha - tr K^{-1}).
  out.gradient(P) = -0.5 * noise * (ws.alpha.squaredNorm() - ws.K.diagonal().sum());
}

// One factorisation serves both: with a mean (not zero), beta is profiled out of
// y before the NLL of the residual is taken.
NllEvaluation nll_with_optional_mean(const Kernel& kernel, double log_noise_variance, const MeanFunction* mean,
                                     const Eigen::MatrixXd* X, const Eigen::MatrixXd& Z, const Eigen::VectorXd& y,
                                     bool with_gradient, GpWorkspace& ws, Eigen::VectorXd* beta,
                                     const JitterPolicy& jitter) {
  NllEvaluation out;
  const double noise = std::exp(log_noise_variance);
  const CholeskyResult chol = factorize_covariance(kernel, noise, Z, ws, jitter);
  out.jitter = chol.jitter;
  if (!chol.ok()) {
    out.status = chol.status == CholeskyResult::Status::NonFinite ? NllEvaluation::Status::NonFinite
                                                                 : NllEvaluation::Status::NotPositiveDefinite;
    out.message = chol.message;
    return out;
  }
  if (!mean || mean->kind() == MeanKind::Zero) {
    if (beta) beta->resize(0);
    nll_from_factor(kernel, noise, Z, y, with_gradient, ws, out);
    return out;
  }
  Eigen::MatrixXd H;
  mean->basis(*X, H);
  Eigen::MatrixXd KinvH = H;
  cholesky_solve(ws.K, KinvH);
  // Generalised least squares; the complete orthogonal decomposition gives the
  // minimum-norm solution when basis columns are collinear (a joint that never moves).
  const Eigen::VectorXd b =
      (H.transpose() * KinvH).completeOrthogonalDecomposition().solve(KinvH.transpose() * y);
  if (!b.allFinite()) {
    out.message = "the mean's least-squares coefficients are not finite at these hyperparameters";
    return out;
  }
  if (beta) *beta = b;
  nll_from_factor(kernel, noise, Z, y - H * b, with_gradient, ws, out);
  return out;
}

}  // namespace

CholeskyResult fit_result(const NllEvaluation& e) {
  CholeskyResult r;
  r.jitter = e.jitter;
  r.message = e.message;
  if (!e.ok())
    r.status = e.status == NllEvaluation::Status::NonFinite ? CholeskyResult::Status::NonFinite
                                                            : CholeskyResult::Status::NotPositiveDefinite;
  return r;
}

double gaussian_nll(double y_dot_alpha, double log_det, Eigen::Index rows) {
  constexpr double kLog2Pi = 1.8378770664093454836;
  return 0.5 * (y_dot_alpha + log_det + static_cast<double>(rows) * kLog2Pi);
}

NllEvaluation evaluate_nll(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, bool with_gradient, GpWorkspace& ws,
                           const JitterPolicy& jitter) {
  return nll_with_optional_mean(kernel, log_noise_variance, nullptr, nullptr, Z, y, with_gradient, ws, nullptr,
                                jitter);
}

NllEvaluation evaluate_profiled_nll(const Kernel& kernel, double log_noise_variance, const MeanFunction& mean,
                                    const Eigen::MatrixXd& X, const Eigen::MatrixXd& Z, const Eigen::VectorXd& y,
                                    bool with_gradient, GpWorkspace& ws, Eigen::VectorXd* beta,
                                    const JitterPolicy& jitter) {
  return nll_with_optional_mean(kernel, log_noise_variance, &mean, &X, Z, y, with_gradient, ws, beta, jitter);
}

GpRegressor::GpRegressor(std::unique_ptr<Kernel> kernel, double log_noise_variance)
    : kernel_(std::move(kernel)), log_noise_(log_noise_variance) {}

GpRegressor::GpRegressor(const GpRegressor& other)
    : kernel_(other.kernel_ ? other.kernel_->clone() : nullptr),
      log_noise_(other.log_noise_),
      alpha_(other.alpha_),
      y_(other.y_),
      L_(other.L_),
      La_(other.La_),
      sparse_b_(other.sparse_b_),
      jitter_(other.jitter_),
      nll_(other.nll_) {}

GpRegressor& GpRegressor::operator=(const GpRegressor& other) {
  if (this != &other) *this = GpRegressor(other);
  return *this;
}

CholeskyResult GpRegressor::fit(const Eigen::MatrixXd& Z, const Eigen::VectorXd& y, bool keep_factor, GpWorkspace& ws,
                                const JitterPolicy& jitter) {
  const CholeskyResult chol = factorize_covariance(*kernel_, std::exp(log_noise_), Z, ws, jitter);
  if (!chol.ok()) return chol;
  nll_ = solve_and_nll(ws.K, y, alpha_);
  y_ = y;
  La_.resize(0, 0);
  sparse_b_.resize(0);
  jitter_ = chol.jitter;
  if (keep_factor) {
    L_ = ws.K.triangularView<Eigen::Lower>();
  } else {
    L_.resize(0, 0);
  }
  return chol;
}

void GpRegressor::set_state(const Eigen::VectorXd& alpha, double jitter, double nll) {
  alpha_ = alpha;
  y_.resize(0);
  jitter_ = jitter;
  nll_ = nll;
  L_.resize(0, 0);
  La_.resize(0, 0);
  sparse_b_.resize(0);
}

void GpRegressor::set_sparse_state(const Eigen::VectorXd& alpha, double jitter, double objective,
                                   Eigen::MatrixXd inducing_factor, Eigen::MatrixXd posterior_factor) {
  if (posterior_factor.rows() != alpha.size() || posterior_factor.cols() != alpha.size() ||
      (inducing_factor.size() > 0 && inducing_factor.rows() != alpha.size()))
    throw Error("GpRegressor::set_sparse_state: factors and alpha disagree in size");
  set_state(alpha, jitter, objective);
  L_ = std::move(inducing_factor);
  La_ = std::move(posterior_factor);
}

CholeskyResult GpRegressor::compute_factor(const Eigen::MatrixXd& Z, GpWorkspace& ws) {
  // Reproduce the stored fit's matrix exactly: same noise, same jitter (a sparse
  // GP's Kmm has no noise).
  const double diag_add = (is_sparse() ? 0.0 : std::exp(log_noise_)) + jitter_;
  const CholeskyResult chol = factorize_covariance(*kernel_, diag_add, Z, ws, JitterPolicy{});
  if (chol.ok()) L_ = ws.K.triangularView<Eigen::Lower>();
  return chol;
}

Eigen::VectorXd GpRegressor::fitted_targets() const {
  if (is_sparse()) throw Error("a sparse GP does not keep its training targets");
  if (y_.size() == alpha_.size()) return y_;
  if (!has_factor()) throw Error("the fitted targets need the Cholesky factor; call compute_factor first");
  const auto L = L_.triangularView<Eigen::Lower>();
  Eigen::VectorXd t = L.transpose() * alpha_;
  return L * t;
}

Eigen::VectorXd GpRegressor::inverse_diagonal() const {
  if (is_sparse()) throw Error("leave-one-out predictions need an exact GP; this one is sparse (inducing points)");
  if (!has_factor()) throw Error("the inverse's diagonal needs the Cholesky factor; call compute_factor first");
  // diag(K^-1)_i = |column i of L^-1|^2, K = L L'.
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Identity(L_.rows(), L_.cols());
  L_.triangularView<Eigen::Lower>().solveInPlace(inverse);
  return inverse.colwise().squaredNorm().transpose();
}

CholeskyResult GpRegressor::update(Eigen::Index drop, const Eigen::MatrixXd& Z, Eigen::Index added,
                                   const Eigen::VectorXd& y) {
  if (is_sparse())
    throw Error("online updates need an exact GP; this one is sparse (inducing points): retrain it with the new rows");
  if (!has_factor()) throw Error("an online update needs the Cholesky factor; call compute_factor first");
  const Eigen::Index old_rows = L_.rows(), kept = old_rows - drop, rows = kept + added;
  if (drop < 0 || added < 0 || kept < 0 || Z.rows() != rows || y.size() != rows)
    throw Error("GpRegressor::update: " + std::to_string(Z.rows()) + " rows given for " + std::to_string(kept) +
                " kept and " + std::to_string(added) + " added");
  auto failed = [this](CholeskyResult::Status status, const char* message) {
    L_.resize(0, 0);  // the factor is no longer that of any training set
    CholeskyResult r;
    r.status = status;
    r.message = message;
    return r;
  };
  // Everything happens inside L_'s buffer: a sliding window (drop == added)
  // never allocates an N x N matrix, whose page faults would cost more than
  // the arithmetic. Dropping the oldest rows: K22 = L21 L21^T + L22 L22^T, so
  // the kept block's factor is L22 updated by each column of L21.
  if (drop > 0) {
    Eigen::VectorXd x(kept);
    for (Eigen::Index c = 0; c < drop; ++c) {
      x = L_.block(drop, c, kept, 1);
      rank_one_update(L_.bottomRightCorner(kept, kept), x);
    }
    // Move the kept block to the top left: each destination precedes its
    // source in column-major order, so a forward pass never overwrites a source.
    for (Eigen::Index j = 0; j < kept; ++j)
      for (Eigen::Index i = j; i < kept; ++i) L_(i, j) = L_(i + drop, j + drop);
  }
  if (rows > old_rows) {
    L_.conservativeResize(rows, rows);
  } else if (rows < old_rows) {
    Eigen::MatrixXd smaller = L_.topLeftCorner(rows, rows);
    L_ = std::move(smaller);
  }
  L_.topRightCorner(rows, rows - kept).setZero();
  for (Eigen::Index j = 0; j < kept; ++j) L_.col(j).head(j).setZero();
  // Appending: [[L, 0], [W^T, chol(C - W^T W)]] with W = L^-1 B.
  if (added > 0) {
    Eigen::MatrixXd B, C;
    kernel_->cross(Z.topRows(kept), Z.bottomRows(added), B);
    kernel_->cross(Z.bottomRows(added), Z.bottomRows(added), C);
    C.diagonal().array() += std::exp(log_noise_) + jitter_;
    if (kept > 0) L_.topLeftCorner(kept, kept).triangularView<Eigen::Lower>().solveInPlace(B);
    C.noalias() -= B.transpose() * B;
    Eigen::LLT<Eigen::MatrixXd> llt(C);
    if (!C.allFinite()) return failed(CholeskyResult::Status::NonFinite, "the kernel matrix with the new rows is not finite");
    if (llt.info() != Eigen::Success)
      return failed(CholeskyResult::Status::NotPositiveDefinite,
                    "the kernel matrix with the new rows is not positive definite at these hyperparameters "
                    "(duplicate rows with a tiny noise variance?); refit the hyperparameters on all rows");
    L_.bottomLeftCorner(added, kept) = B.transpose();
    L_.bottomRightCorner(added, added) = llt.matrixL();
  }
  Eigen::VectorXd alpha;
  const double nll = solve_and_nll(L_, y, alpha);
  if (!std::isfinite(nll) || !alpha.allFinite())
    return failed(CholeskyResult::Status::NonFinite, "the updated GP's weights are not finite");
  alpha_ = std::move(alpha);
  y_ = y;
  nll_ = nll;
  CholeskyResult r;
  r.jitter = jitter_;
  return r;
}

CholeskyResult GpRegressor::add_rows_sparse(const Eigen::MatrixXd& Zm, const Eigen::MatrixXd& Zadded,
                                            const Eigen::VectorXd& yadded) {
  if (!is_sparse()) throw Error("GpRegressor::add_rows_sparse needs a sparse GP; use update for an exact one");
  const Eigen::Index M = La_.rows();
  if (Zm.rows() != M || Zadded.rows() != yadded.size() || Zadded.cols() != Zm.cols())
    throw Error("GpRegressor::add_rows_sparse: " + std::to_string(Zm.rows()) + " inducing rows for a factor of " +
                std::to_string(M) + ", " + std::to_string(Zadded.rows()) + " new rows for " +
                std::to_string(yadded.size()) + " targets");
  const double s = std::exp(log_noise_);
  // A beta = b = Kmn y with beta = s alpha.
  if (sparse_b_.size() != M) {  // once: from a fit or a file, which keep only A's factor and alpha
    const Eigen::VectorXd t = La_.triangularView<Eigen::Lower>().transpose() * alpha_;
    sparse_b_ = La_.triangularView<Eigen::Lower>() * t;
    sparse_b_ *= s;
  }
  Eigen::VectorXd b = sparse_b_;
  Eigen::MatrixXd Kam;
  kernel_->cross(Zadded, Zm, Kam);  // added x M
  b.noalias() += Kam.transpose() * yadded;
  sparse_b_ = b;
  Eigen::VectorXd x(M);
  for (Eigen::Index i = 0; i < Kam.rows(); ++i) {
    x = Kam.row(i).transpose() / std::sqrt(s);
    rank_one_update(La_, x);
  }
  La_.triangularView<Eigen::Lower>().solveInPlace(b);
  La_.triangularView<Eigen::Lower>().transpose().solveInPlace(b);
  CholeskyResult r;
  r.jitter = jitter_;
  if (!b.allFinite() || !La_.allFinite()) {
    r.status = CholeskyResult::Status::NonFinite;
    r.message = "the sparse GP's weights with the new rows are not finite";
    return r;
  }
  alpha_ = b / s;
  return r;
}

void GpRegressor::predict_mean(const Eigen::MatrixXd& Zstar, const Eigen::MatrixXd& Z, Eigen::VectorXd& mean) const {
  Eigen::MatrixXd Ks;
  kernel_->cross(Zstar, Z, Ks);
  mean.noalias() = Ks * alpha_;
}

void GpRegressor::predict_variance(const Eigen::MatrixXd& Zstar, const Eigen::MatrixXd& Z, Eigen::VectorXd& var) const {
  if (!has_factor()) throw Error("predictive variance needs the Cholesky factor; call compute_factor first");
  Eigen::MatrixXd V;
  kernel_->cross(Z, Zstar, V);  // N x M
  L_.triangularView<Eigen::Lower>().solveInPlace(V);
  kernel_->diagonal(Zstar, var);
  var -= V.colwise().squaredNorm().transpose();
  if (is_sparse()) {
    kernel_->cross(Z, Zstar, V);
    La_.triangularView<Eigen::Lower>().solveInPlace(V);
    var += V.colwise().squaredNorm().transpose();
  }
  var = var.cwiseMax(0.0);
}

double GpRegressor::predict_mean_one(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> krow,
                                     KernelScratch& scratch) const {
  kernel_->row(z, Z, krow, scratch);
  return krow.dot(alpha_);
}

double GpRegressor::predict_variance_one(const double* z, int feature_dim,
                                         const Eigen::Ref<const Eigen::VectorXd>& krow, Eigen::Ref<Eigen::VectorXd> v,
                                         KernelScratch& scratch) const {
  v = krow;
  L_.triangularView<Eigen::Lower>().solveInPlace(v);  // dtrsv
  double var = kernel_->self(z, feature_dim, scratch) - v.squaredNorm();
  if (is_sparse()) {
    v = krow;
    La_.triangularView<Eigen::Lower>().solveInPlace(v);
    var += v.squaredNorm();
  }
  return std::max(0.0, var);
}

}  // namespace gipdyn
