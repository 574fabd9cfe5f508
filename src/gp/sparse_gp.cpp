#include "gipdyn/gp/sparse_gp.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {
namespace {

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

// For each block of rows [i0, i0 + m): ws.Zb = its features and
// ws.Vb = Lm^-1 k(Zm, Zb), its columns of V (ws.Lm must hold the factor).
template <class Visit>
void for_each_block(const Kernel& kernel, const Eigen::MatrixXd& Z, const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws,
                    Visit&& visit) {
  for (Eigen::Index i0 = 0; i0 < Z.rows(); i0 += kRowBlock) {
    const Eigen::Index m = std::min(kRowBlock, Z.rows() - i0);
    ws.Zb = Z.middleRows(i0, m);
    kernel.cross(Zm, ws.Zb, ws.Vb);
    ws.Lm.triangularView<Eigen::Lower>().solveInPlace(ws.Vb);
    visit(i0, m);
  }
}

Eigen::MatrixXd full_from_lower(const Eigen::MatrixXd& lower) {
  Eigen::MatrixXd full = lower.selfadjointView<Eigen::Lower>();
  return full;
}

// The pass every evaluation needs, in the whitened basis V = Lm^-1 Kmn (which
// keeps an ill-conditioned Kmm out of every subtraction): ws.VVt = V V^T,
// ws.Vy = V y, the sum of k(z_i, z_i); then B = I + V V^T / s = Lm^-1 A Lm^-T
// factorised into ws.LB and c = B^-1 V y (beta = A^-1 Kmn y = Lm^-T c).
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
  ws.Lm.triangularView<Eigen::StrictlyUpper>().setZero();
  ws.VVt.setZero(M, M);
  ws.Vy.setZero(M);
  for_each_block(kernel, Z, Zm, ws, [&](Eigen::Index i0, Eigen::Index m) {
    ws.VVt.selfadjointView<Eigen::Lower>().rankUpdate(ws.Vb);
    ws.Vy.noalias() += ws.Vb * y.segment(i0, m);
    kernel.diagonal(ws.Zb, ws.d);
    out.diag_sum += ws.d.sum();
  });
  ws.VVt = full_from_lower(ws.VVt);
  auto build_b = [&](Eigen::MatrixXd& B) {
    B = ws.VVt / s;
    B.diagonal().array() += 1.0;
  };
  build_b(ws.LB);
  const CholeskyResult b = cholesky_with_jitter(ws.LB, build_b, JitterPolicy{});
  if (!b.ok()) {
    out.status = b;
    out.status.message = "sparse posterior matrix: " + b.message;
    return out;
  }
  ws.LB.triangularView<Eigen::StrictlyUpper>().setZero();
  ws.c = ws.Vy;
  cholesky_solve(ws.LB, ws.c);
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
  const double N = static_cast<double>(Z.rows()), M = static_cast<double>(Zm.rows());
  const FirstPass pass = first_pass(kernel, s, Z, y, Zm, ws, jitter);
  ws.inducing_eps = pass.eps;
  out.jitter = pass.status.jitter - pass.eps;  // eps is part of the model, not a repair
  if (!pass.status.ok()) {
    out.status = to_nll_status(pass.status);
    out.message = pass.status.message;
    return out;
  }
  const double yy = y.squaredNorm(), vy_c = ws.Vy.dot(ws.c);
  const double log_det_b = 2.0 * ws.LB.diagonal().array().log().sum();
  const double trace_term = (pass.diag_sum - ws.VVt.trace()) / (2.0 * s);  // tr(Knn - Q) / (2 s)
  out.nll = gaussian_nll((yy - vy_c / s) / s, N * std::log(s) + log_det_b, Z.rows()) + trace_term;
  if (!std::isfinite(out.nll)) {
    out.message = "sparse marginal likelihood bound is not finite at these hyperparameters";
    return out;
  }
  out.status = NllEvaluation::Status::Ok;
  if (!with_gradient) return out;

  ws.Binv = inverse_from_factor(ws.LB);
  if (ws.Binv.size() == 0) {
    out.status = NllEvaluation::Status::InversionFailed;
    out.message = "could not invert the sparse posterior matrix (LAPACK potri failed)";
    return out;
  }
  // dF = sum W_nm o dKnm + sum W_mm o dKmm + sum_i dk(z_i, z_i) / (2 s) with, for
  // alpha = (y - V^T c / s) / s,
  //   W_nm = [V^T (B^-1 - I) - alpha c^T] Lm^-1 / s,
  //   W_mm = Lm^-T [(B + B^-1 + c c^T / s^2) / 2 - I] Lm^-1.
  const int P = kernel.num_params();
  out.gradient = Eigen::VectorXd::Zero(P + 1);
  ws.C = ws.Binv;
  ws.C.diagonal().array() -= 1.0;
  const Eigen::VectorXd half_over_s = Eigen::VectorXd::Constant(std::min<Eigen::Index>(kRowBlock, Z.rows()), 0.5 / s);
  for_each_block(kernel, Z, Zm, ws, [&](Eigen::Index i0, Eigen::Index m) {
    ws.alpha_b = (y.segment(i0, m) - ws.Vb.transpose() * ws.c / s) / s;
    ws.Wb.noalias() = ws.Vb.transpose() * ws.C;
    ws.Wb.noalias() -= ws.alpha_b * ws.c.transpose();
    ws.Lm.triangularView<Eigen::Lower>().solveInPlace<Eigen::OnTheRight>(ws.Wb);  // (...) Lm^-1
    ws.Wb /= s;
    kernel.contract_cross(ws.Zb, Zm, ws.Wb, out.gradient.head(P), ws.scratch);
    kernel.contract_diagonal(ws.Zb, half_over_s.head(m), out.gradient.head(P), ws.diagonal_scratch);
  });
  ws.H = 0.5 * (ws.VVt / s + ws.Binv + ws.c * ws.c.transpose() / (s * s));
  ws.H.diagonal().array() -= 0.5;  // B = I + V V^T / s: (B + B^-1) / 2 - I = (V V^T / s + B^-1 - I) / 2
  ws.Lm.triangularView<Eigen::Lower>().transpose().solveInPlace(ws.H);                           // Lm^-T H
  ws.Lm.triangularView<Eigen::Lower>().solveInPlace<Eigen::OnTheRight>(ws.H);        // ... Lm^-1
  kernel.contract(Zm, ws.H, out.gradient.head(P), ws.scratch);
  // d/dlog s: s/2 (tr Sigma^-1 - alpha^T alpha) - trace_term, with
  // tr Sigma^-1 = (N - M + tr B^-1) / s and alpha^T alpha = (y^T y - 2 c^T V y / s + c^T V V^T c / s^2) / s^2.
  const double trace_sigma_inv = (N - M + ws.Binv.trace()) / s;
  const double alpha_sq = (yy - 2.0 * vy_c / s + ws.c.dot(ws.VVt * ws.c) / (s * s)) / (s * s);
  out.gradient(P) = 0.5 * s * (trace_sigma_inv - alpha_sq) - trace_term;
  return out;
}

SparsePosterior fit_sparse(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws,
                           const JitterPolicy& jitter) {
  SparsePosterior out;
  const NllEvaluation e = evaluate_vfe(kernel, log_noise_variance, Z, y, Zm, false, ws, jitter);
  out.status = fit_result(e);
  if (!e.ok()) return out;
  out.objective = e.nll;
  // Kmm's diagonal addition, for compute_factor to rebuild Lm: eps plus any repair.
  out.jitter = ws.inducing_eps + e.jitter;
  out.alpha = ws.Lm.triangularView<Eigen::Lower>().transpose().solve(ws.c) / std::exp(log_noise_variance);  // beta / s, beta = Lm^-T c
  out.inducing_factor = ws.Lm;
  out.posterior_factor = ws.Lm * ws.LB;  // A = Lm B Lm^T; both strict upper triangles are zero
  return out;
}

std::vector<Eigen::Index> select_inducing_rows(const Kernel& kernel, const Eigen::MatrixXd& Z, Eigen::Index count) {
  const Eigen::Index N = Z.rows();
  if (count < 1 || count > N)
    throw Error("inducing points: " + std::to_string(count) + " requested from " + std::to_string(N) +
                " rows; choose between 1 and the number of training rows");
  const Eigen::Index pool_size = std::min(N, std::max<Eigen::Index>(20 * count, 20000));
  require_memory(8.0 * static_cast<double>(pool_size) * static_cast<double>(count + Z.cols()),
                 "choosing " + std::to_string(count) + " inducing rows among " + std::to_string(pool_size),
                 "ask for fewer inducing points");
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
