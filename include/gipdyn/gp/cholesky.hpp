#pragma once
// Cholesky factorisation with a bounded jitter fallback. Numerical code reports
// failure through a status and a message; it does not throw.
#include <Eigen/Dense>
#include <functional>
#include <string>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

struct JitterPolicy {
  // Jitter is relative to the mean of the diagonal: first try none, then
  // initial_relative, growing by `growth`, up to max_relative.
  double initial_relative = 1e-10;
  double growth = 10.0;
  double max_relative = 1e-4;
};

struct CholeskyResult {
  enum class Status { Ok, NotPositiveDefinite, NonFinite };
  Status status = Status::Ok;
  double jitter = 0.0;  // absolute value added to the diagonal (0 if none was needed)
  std::string message;
  bool ok() const { return status == Status::Ok; }
};

// Factorises the symmetric matrix whose lower triangle is in K into K = L L^T
// in place (lower triangle); false where it is not positive definite. From
// 1536 rows on, tile by tile on `threads` threads (0: the machine's), each
// tile by the same single-threaded BLAS call whichever thread runs it, so the
// factor is the same for every thread count; smaller matrices are one LAPACK
// potrf.
bool cholesky_in_place(Eigen::MatrixXd& K, int threads = 0);

// cholesky_in_place, with jitter: where the factorisation fails, rebuild(K)
// restores the lower triangle and it is retried with growing jitter.
CholeskyResult cholesky_with_jitter(Eigen::MatrixXd& K, const std::function<void(Eigen::MatrixXd&)>& rebuild,
                                    const JitterPolicy& policy = {});

// The jitter policy for any factorisation: calls factorize(0), then
// factorize(jitter) for the policy's growing jitters (relative to
// |mean_diagonal|) until it returns true; NotPositiveDefinite with a message
// when the largest one fails too. cholesky_with_jitter uses it, and so does
// the distributed factorisation.
CholeskyResult factorize_with_jitter(double mean_diagonal, const std::function<bool(double jitter)>& factorize,
                                     const JitterPolicy& policy);

// Solves (L L^T) x = b in place, L from cholesky_with_jitter.
void cholesky_solve(const Eigen::MatrixXd& L, Eigen::Ref<Eigen::MatrixXd> b);

// Replaces the Cholesky factor (lower) by the lower triangle of (L L^T)^{-1}:
// false where L is singular. As cholesky_in_place, from 1536 rows on tile by
// tile on `threads` threads (0: the machine's), the same bits for every thread
// count (L^{-1}, then L^{-T} L^{-1}); smaller matrices are one LAPACK potri.
bool cholesky_inverse_in_place(Eigen::MatrixXd& L, int threads = 0);

}  // namespace gipdyn
