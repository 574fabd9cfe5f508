#pragma once
// Sparse GP regression for one output with M inducing inputs Zm chosen among
// the N training rows: Titsias' variational free energy (VFE), docs/method.md
// section 14. With Kmm = k(Zm, Zm) + eps I, Knm = k(Z, Zm), s = sigma_n^2,
// Q = Knm Kmm^-1 Kmn and A = Kmm + Kmn Knm / s,
//
//   F = -log N(y | 0, Q + s I) + tr(Knn - Q) / (2 s)      (minimised)
//   mean(x*) = k(x*, Zm) beta / s,  beta = A^-1 Kmn y
//   var(x*)  = k(x*, x*) - k*^T Kmm^-1 k* + k*^T A^-1 k*
//
// F bounds the exact NLL from above and equals it when Zm holds every row.
// One evaluation costs O(N M^2) time and O(B M + M^2) memory: the rows are
// visited in blocks of B, twice with the gradient, and no N x N or N x M
// matrix is formed, so N is limited by time, not memory.
#include <Eigen/Dense>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

// Mutable buffers of sparse evaluations (one per thread); every matrix is M x M
// or B x M, reused across an optimiser's evaluations.
struct SparseGpWorkspace {
  Eigen::MatrixXd Lm, LB, VVt, Binv, C, H, Vb, Wb, Zb;
  Eigen::VectorXd Vy, c, d, alpha_b;
  double inducing_eps = 0.0;  // the eps added to Kmm's diagonal by the last evaluation
  // Two, so that the diagonal's small blocks do not shrink the cross
  // contraction's large buffers (a reallocation per row block).
  KernelScratch scratch, diagonal_scratch;
};

// eps of Kmm, relative to the mean of its diagonal: the inducing rows of a
// polynomial kernel span a finite feature space, so Kmm may be singular.
constexpr double kInducingJitter = 1e-8;

// F and (optionally) its gradient w.r.t. [kernel log-params, log noise variance].
// Reports failure through the status, like evaluate_nll.
NllEvaluation evaluate_vfe(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, const Eigen::MatrixXd& Zm, bool with_gradient,
                           SparseGpWorkspace& ws, const JitterPolicy& jitter = {});

// What prediction needs from a sparse fit.
struct SparsePosterior {
  CholeskyResult status;
  Eigen::VectorXd alpha;             // beta / s: mean(x*) = k(x*, Zm) alpha
  Eigen::MatrixXd inducing_factor;   // lower Cholesky factor of Kmm (+ eps + jitter)
  Eigen::MatrixXd posterior_factor;  // lower Cholesky factor of A
  double jitter = 0.0;               // eps + any jitter added to Kmm
  double objective = 0.0;            // F
};
SparsePosterior fit_sparse(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                           const Eigen::VectorXd& y, const Eigen::MatrixXd& Zm, SparseGpWorkspace& ws,
                           const JitterPolicy& jitter = {});

// Greedy variance selection (a pivoted Cholesky factorisation of k(Z, Z)): the
// next inducing row is the one the chosen rows explain least. Deterministic.
// Stops early when every row is explained to 1e-12 of the largest variance
// (a polynomial kernel's feature space may hold fewer than `count` directions).
// Rows beyond a constant-step pool of max(20 count, 20000) are not candidates,
// so memory stays O(pool x count).
std::vector<Eigen::Index> select_inducing_rows(const Kernel& kernel, const Eigen::MatrixXd& Z, Eigen::Index count);

}  // namespace gipdyn
