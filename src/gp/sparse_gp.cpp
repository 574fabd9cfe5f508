#include "gipdyn/gp/sparse_gp.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {
namespace {

constexpr double kLog2Pi = 1.8378770664093454836;
constexpr Eigen::Index kRowBlock = 1024;  // rows per pass block: B x M buffers

NllEvaluation::Status to_nll_status(const CholeskyResult& r) {
  return r.status == CholeskyResult::Status::NonFinite ? NllEvaluation::Status::NonFinite
                                                       : NllEvaluation::Status::NotPositiveDefinite;
}

// ws.Lm = Cholesky factor of Kmm + eps I (+ jitter).
CholeskyResult factor_inducing(const Kernel& kernel, const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws,
                               const JitterPolicy& jitter, double& eps) {
  auto build = [&](Eigen::MatrixXd& K) {
    K.resize(Zm.rows(), Zm.rows());
    kernel.gram_lower(Zm, K, ws.scratch);
    eps = kInducingJitter * std::abs(K.diagonal().mean());
    K.diagonal().array() += eps;
  };
  build(ws.Lm);
  CholeskyResult r = cholesky_with_jitter(ws.Lm, build, jitter);
  r.jitter += eps;
  if (!r.ok()) r.message = "inducing kernel matrix: " + r.message;
  return r;
}

// For each block of rows [i0, i0 + m): ws.Zb = its features, ws.Kb = k(Zb, Zm).
template <class Visit>
void for_each_block(const Kernel& kernel, const Eigen::MatrixXd& Z, const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws,
                    Visit&& visit) {
  for (Eigen::Index i0 = 0; i0 < Z.rows(); i0 += kRowBlock) {
    const Eigen::Index m = std::min(kRowBlock, Z.rows() - i0);
    ws.Zb = Z.middleRows(i0, m);
    kernel.cross(ws.Zb, Zm, ws.Kb);
    visit(i0, m);
  }
}

Eigen::MatrixXd full_from_lower(const Eigen::MatrixXd& lower) {
  Eigen::MatrixXd full = lower.selfadjointView<Eigen::Lower>();
  return full;
}

// The pass every evaluation needs: S = Kmn Knm, r = Kmn y, sum of k(z_i, z_i),
// then A = Kmm + S / s factorised into ws.La and beta = A^-1 r.
struct FirstPass {
  CholeskyResult status;
  double diag_sum = 0.0;
  double eps = 0.0;
};
FirstPass first_pass(const Kernel& kernel, double s, const Eigen::MatrixXd& Z, const Eigen::VectorXd& y,
                     const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws, const JitterPolicy& jitter) {
  FirstPass out;
  const Eigen::Index M = Zm.rows();
  out.status = factor_inducing(kernel, Zm, ws, jitter, out.eps);
  if (!out.status.ok()) return out;
  ws.S.setZero(M, M);
  ws.r.setZero(M);
  for_each_block(kernel, Z, Zm, ws, [&](Eigen::Index i0, Eigen::Index m) {
    ws.S.selfadjointView<Eigen::Lower>().rankUpdate(ws.Kb.transpose());
    ws.r.noalias() += ws.Kb.transpose() * y.segment(i0, m);
    kernel.diagonal(ws.Zb, ws.d);
    out.diag_sum += ws.d.sum();
  });
  ws.S = full_from_lower(ws.S);
  auto build_a = [&](Eigen::MatrixXd& A) {
    A = ws.Lm * ws.Lm.transpose();  // Kmm + eps (+ jitter), from its factor
    A += ws.S / s;
  };
  ws.Lm.triangularView<Eigen::StrictlyUpper>().setZero();
  build_a(ws.La);
  const CholeskyResult a = cholesky_with_jitter(ws.La, build_a, JitterPolicy{});
  if (!a.ok()) {
    out.status = a;
    out.status.message = "sparse posterior matrix: " + a.message;
    return out;
  }
  ws.La.triangularView<Eigen::StrictlyUpper>().setZero();
  ws.beta = ws.r;
  cholesky_solve(ws.La, ws.beta);
  return out;
}

Eigen::MatrixXd inverse_from_factor(const Eigen::MatrixXd& L) {
  Eigen::MatrixXd inv = L;
  if (!cholesky_inverse_in_place(inv)) return {};
  return full_from_lower(inv);
}

}  // namespace

NllEvaluation evaluate_vfe(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, const Eigen::MatrixXd& Zm, bool with_gradient,
                           SparseGpWorkspace& ws, const JitterPolicy& jitter) {
  NllEvaluation out;
  const double s = std::exp(log_noise_variance);
  const double N = static_cast<double>(Z.rows());
  const FirstPass pass = first_pass(kernel, s, Z, y, Zm, ws, jitter);
  out.jitter = pass.status.jitter;
  if (!pass.status.ok()) {
    out.status = to_nll_status(pass.status);
    out.message = pass.status.message;
    return out;
  }
  ws.Kinv = inverse_from_factor(ws.Lm);
  if (ws.Kinv.size() == 0) {
    out.status = NllEvaluation::Status::InversionFailed;
    out.message = "could not invert the inducing kernel matrix (LAPACK potri failed)";
    return out;
  }
  const double yy = y.squaredNorm(), r_beta = ws.r.dot(ws.beta);
  const double log_det = 2.0 * (ws.La.diagonal().array().log().sum() - ws.Lm.diagonal().array().log().sum());
  const double trace_q = ws.Kinv.cwiseProduct(ws.S).sum();
  const double trace_term = (pass.diag_sum - trace_q) / (2.0 * s);
  out.nll = 0.5 * (N * kLog2Pi + N * std::log(s) + log_det + (yy - r_beta / s) / s) + trace_term;
  if (!std::isfinite(out.nll)) {
    out.message = "sparse marginal likelihood bound is not finite at these hyperparameters";
    return out;
  }
  out.status = NllEvaluation::Status::Ok;
  if (!with_gradient) return out;

  ws.Ainv = inverse_from_factor(ws.La);
  if (ws.Ainv.size() == 0) {
    out.status = NllEvaluation::Status::InversionFailed;
    out.message = "could not invert the sparse posterior matrix (LAPACK potri failed)";
    return out;
  }
  // dF = sum W_nm o dKnm + sum W_mm o dKmm + sum_i dk(z_i, z_i) / (2 s), with
  // W_nm = Knm (A^-1 - Kmm^-1) / s - alpha beta^T / s, alpha = (y - Knm beta / s) / s.
  const int P = kernel.num_params();
  out.gradient = Eigen::VectorXd::Zero(P + 1);
  ws.C = (ws.Ainv - ws.Kinv) / s;
  const Eigen::VectorXd half_over_s = Eigen::VectorXd::Constant(std::min<Eigen::Index>(kRowBlock, Z.rows()), 0.5 / s);
  for_each_block(kernel, Z, Zm, ws, [&](Eigen::Index i0, Eigen::Index m) {
    ws.alpha_b = (y.segment(i0, m) - ws.Kb * ws.beta / s) / s;
    ws.Wb.noalias() = ws.Kb * ws.C;
    ws.Wb.noalias() -= ws.alpha_b * (ws.beta.transpose() / s);
    kernel.contract_cross(ws.Zb, Zm, ws.Wb, out.gradient.head(P), ws.scratch);
    kernel.contract_diagonal(ws.Zb, half_over_s.head(m), out.gradient.head(P), ws.scratch);
  });
  ws.Wmm = -0.5 * (ws.Kinv - ws.Ainv - ws.beta * ws.beta.transpose() / (s * s));
  ws.Wmm.noalias() += ws.Kinv * ws.S * ws.Kinv / (2.0 * s);
  kernel.contract(Zm, ws.Wmm, out.gradient.head(P), ws.scratch);
  // d/dlog s: s/2 (tr Sigma^-1 - alpha^T alpha) - trace_term.
  const double trace_sigma_inv = N / s - ws.Ainv.cwiseProduct(ws.S).sum() / (s * s);
  const double alpha_sq = (yy - 2.0 * r_beta / s + ws.beta.dot(ws.S * ws.beta) / (s * s)) / (s * s);
  out.gradient(P) = 0.5 * s * (trace_sigma_inv - alpha_sq) - trace_term;
  return out;
}

SparsePosterior fit_sparse(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws,
                           const JitterPolicy& jitter) {
  SparsePosterior out;
  const NllEvaluation e = evaluate_vfe(kernel, log_noise_variance, Z, y, Zm, false, ws, jitter);
  out.jitter = e.jitter;
  if (!e.ok()) {
    out.status.status = e.status == NllEvaluation::Status::NonFinite ? CholeskyResult::Status::NonFinite
                                                                      : CholeskyResult::Status::NotPositiveDefinite;
    out.status.message = e.message;
    return out;
  }
  out.status.jitter = e.jitter;
  out.objective = e.nll;
  out.alpha = ws.beta / std::exp(log_noise_variance);
  out.inducing_factor = ws.Lm;
  out.posterior_factor = ws.La;
  return out;
}

std::vector<Eigen::Index> select_inducing_rows(const Kernel& kernel, const Eigen::MatrixXd& Z, Eigen::Index count) {
  const Eigen::Index N = Z.rows();
  if (count < 1 || count > N)
    throw Error("inducing points: " + std::to_string(count) + " requested from " + std::to_string(N) +
                " rows; choose between 1 and the number of training rows");
  const Eigen::Index pool_size = std::min(N, std::max<Eigen::Index>(20 * count, 20000));
  const std::vector<Eigen::Index> pool = constant_step_indices(N, pool_size);
  const Eigen::MatrixXd Zp = Z(pool, Eigen::all);
  Eigen::VectorXd d;
  kernel.diagonal(Zp, d);
  const double floor = 1e-12 * std::max(d.maxCoeff(), 1e-300);
  Eigen::MatrixXd L(pool_size, count);
  Eigen::VectorXd krow(pool_size);
  Eigen::VectorXd zp(Z.cols());
  KernelScratch scratch;
  std::vector<Eigen::Index> chosen;
  for (Eigen::Index m = 0; m < count; ++m) {
    Eigen::Index p = 0;
    if (d.maxCoeff(&p) <= floor) break;
    zp = Zp.row(p).transpose();
    kernel.row(zp.data(), Zp, krow, scratch);
    krow.noalias() -= L.leftCols(m) * L.row(p).head(m).transpose();
    L.col(m) = krow / std::sqrt(d(p));
    d -= L.col(m).cwiseAbs2();
    d(p) = 0.0;
    chosen.push_back(pool[static_cast<size_t>(p)]);
  }
  return chosen;
}

}  // namespace gipdyn
