#include "gipdyn/gp/cholesky.hpp"

#include <cblas.h>
#include <lapacke.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "gipdyn/parallel_tasks.hpp"

namespace gipdyn {

namespace {

// The tiled factorisation's tile side, and the matrix side from which it
// replaces LAPACK's potrf (smaller matrices gain nothing from the cores).
constexpr lapack_int kTile = 384;
constexpr lapack_int kTiledFrom = 2048;

// Right-looking Cholesky of the lower triangle of the n x n column-major A,
// tile by tile: each step factorises a diagonal tile (LAPACK), solves the
// tiles below it, then updates the trailing tiles, the tiles of a phase run
// by run_tasks on `threads` threads (0: one per core). Every tile's arithmetic
// is the same BLAS call whichever thread runs it (BLAS runs on one thread:
// detail/blas_threads.hpp), so the factor does not depend on the core count.
// Returns LAPACK's info.
lapack_int tiled_potrf_lower(double* A, lapack_int n, lapack_int lda, int threads) {
  const lapack_int tiles = (n + kTile - 1) / kTile;
  auto tile = [&](lapack_int i, lapack_int j) { return A + i * kTile + j * kTile * lda; };
  auto side = [&](lapack_int i) { return std::min(kTile, n - i * kTile); };
  std::vector<std::pair<lapack_int, lapack_int>> trailing;
  for (lapack_int k = 0; k < tiles; ++k) {
    const lapack_int info = LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', side(k), tile(k, k), lda);
    if (info != 0) return info + k * kTile;
    const int below = static_cast<int>(tiles - k - 1);
    run_tasks(below, worker_threads(threads, below), [&](int t) {
      const lapack_int i = k + 1 + t;
      cblas_dtrsm(CblasColMajor, CblasRight, CblasLower, CblasTrans, CblasNonUnit, side(i), side(k), 1.0,
                  tile(k, k), lda, tile(i, k), lda);
    });
    trailing.clear();
    for (lapack_int j = k + 1; j < tiles; ++j)
      for (lapack_int i = j; i < tiles; ++i) trailing.emplace_back(i, j);
    const int updates = static_cast<int>(trailing.size());
    run_tasks(updates, worker_threads(threads, updates), [&](int t) {
      const auto [i, j] = trailing[static_cast<size_t>(t)];
      if (i == j)
        cblas_dsyrk(CblasColMajor, CblasLower, CblasNoTrans, side(i), side(k), -1.0, tile(i, k), lda, 1.0,
                    tile(i, i), lda);
      else
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, side(i), side(j), side(k), -1.0, tile(i, k), lda,
                    tile(j, k), lda, 1.0, tile(i, j), lda);
    });
  }
  return 0;
}

}  // namespace

bool cholesky_in_place(Eigen::MatrixXd& K, int threads) {
  const lapack_int n = static_cast<lapack_int>(K.rows());
  if (n < kTiledFrom) return LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', n, K.data(), n) == 0;
  return tiled_potrf_lower(K.data(), n, n, threads) == 0;
}

CholeskyResult factorize_with_jitter(double mean_diagonal, const std::function<bool(double jitter)>& factorize,
                                     const JitterPolicy& policy) {
  CholeskyResult result;
  double relative = 0.0;
  while (true) {
    result.jitter = relative * std::abs(mean_diagonal);
    if (factorize(result.jitter)) return result;
    relative = relative == 0.0 ? policy.initial_relative : relative * policy.growth;
    if (relative > policy.max_relative * (1.0 + 1e-12)) break;
  }
  std::ostringstream msg;
  msg << "kernel matrix is not positive definite even with jitter " << policy.max_relative
      << " x mean diagonal; raise the noise floor (SearchSettings::min_noise_fraction) or remove duplicate rows";
  result.status = CholeskyResult::Status::NotPositiveDefinite;
  result.message = msg.str();
  return result;
}

CholeskyResult cholesky_with_jitter(Eigen::MatrixXd& K, const std::function<void(Eigen::MatrixXd&)>& rebuild,
                                    const JitterPolicy& policy) {
  const lapack_int n = static_cast<lapack_int>(K.rows());
  if (n == 0) return {};
  const double mean_diag = K.diagonal().mean();
  bool finite = std::isfinite(mean_diag);
  for (lapack_int j = 0; finite && j < n; ++j) finite = K.col(j).segment(j, n - j).allFinite();
  if (!finite) {
    CholeskyResult result;
    result.status = CholeskyResult::Status::NonFinite;
    result.message = "kernel matrix has NaN or Inf entries (check the inputs and the hyperparameters)";
    return result;
  }
  return factorize_with_jitter(
      mean_diag,
      [&](double jitter) {
        if (jitter > 0.0) {
          rebuild(K);
          K.diagonal().array() += jitter;
        }
        return cholesky_in_place(K);
      },
      policy);
}

void cholesky_solve(const Eigen::MatrixXd& L, Eigen::Ref<Eigen::MatrixXd> b) {
  const lapack_int n = static_cast<lapack_int>(L.rows());
  LAPACKE_dpotrs_work(LAPACK_COL_MAJOR, 'L', n, static_cast<lapack_int>(b.cols()), L.data(), n, b.data(),
                 static_cast<lapack_int>(b.outerStride()));
}

bool cholesky_inverse_in_place(Eigen::MatrixXd& L) {
  const lapack_int n = static_cast<lapack_int>(L.rows());
  return LAPACKE_dpotri_work(LAPACK_COL_MAJOR, 'L', n, L.data(), n) == 0;
}

}  // namespace gipdyn
