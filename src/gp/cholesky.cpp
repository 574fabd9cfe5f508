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

// The tiled algorithms' tile side, and the matrix side from which they
// replace LAPACK's single call (smaller matrices gain little from the cores;
// bench/RESULTS.md).
constexpr lapack_int kTile = 384;
constexpr lapack_int kTiledFrom = 1536;

// A column-major n x n matrix cut into square tiles of side `size` (the last
// row and column of tiles smaller).
struct Tiles {
  double* A;
  lapack_int n, lda, size;
  lapack_int count() const { return (n + size - 1) / size; }
  double* at(lapack_int i, lapack_int j) const { return A + i * size + j * size * lda; }
  lapack_int side(lapack_int i) const { return std::min(size, n - i * size); }
};

// The tiles (i, j) of one phase, each task run by run_tasks on `threads`
// threads (0: one per core). Every tile's arithmetic is the same BLAS call
// whichever thread runs it (BLAS runs on one thread: detail/blas_threads.hpp),
// so the result does not depend on the core count.
using TileList = std::vector<std::pair<lapack_int, lapack_int>>;
template <class Task>
void run_phase(const TileList& tiles, int threads, Task&& task) {
  const int count = static_cast<int>(tiles.size());
  run_tasks(count, worker_threads(threads, count), [&](int t) {
    const auto [i, j] = tiles[static_cast<size_t>(t)];
    task(i, j);
  });
}

// Right-looking Cholesky of the lower triangle, tile by tile: each step
// factorises a diagonal tile (LAPACK), solves the tiles below it, then updates
// the trailing tiles. Returns LAPACK's info.
lapack_int tiled_potrf_lower(const Tiles& T, int threads) {
  const lapack_int tiles = T.count();
  TileList phase;
  for (lapack_int k = 0; k < tiles; ++k) {
    const lapack_int info = LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', T.side(k), T.at(k, k), T.lda);
    if (info != 0) return info + k * T.size;
    phase.clear();
    for (lapack_int i = k + 1; i < tiles; ++i) phase.emplace_back(i, k);
    run_phase(phase, threads, [&](lapack_int i, lapack_int) {
      cblas_dtrsm(CblasColMajor, CblasRight, CblasLower, CblasTrans, CblasNonUnit, T.side(i), T.side(k), 1.0,
                  T.at(k, k), T.lda, T.at(i, k), T.lda);
    });
    phase.clear();
    for (lapack_int j = k + 1; j < tiles; ++j)
      for (lapack_int i = j; i < tiles; ++i) phase.emplace_back(i, j);
    run_phase(phase, threads, [&](lapack_int i, lapack_int j) {
      if (i == j)
        cblas_dsyrk(CblasColMajor, CblasLower, CblasNoTrans, T.side(i), T.side(k), -1.0, T.at(i, k), T.lda, 1.0,
                    T.at(i, i), T.lda);
      else
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, T.side(i), T.side(j), T.side(k), -1.0, T.at(i, k),
                    T.lda, T.at(j, k), T.lda, 1.0, T.at(i, j), T.lda);
    });
  }
  return 0;
}

// L <- L^{-1} for the lower triangular L, tile by tile: at step k the tiles
// below the diagonal tile become -L_mk L_kk^{-1}, update the tiles left of
// them, then the tiles left of the diagonal tile are solved with it and it is
// inverted (LAPACK trtri). Returns LAPACK's info (> 0: singular).
lapack_int tiled_trtri_lower(const Tiles& T, int threads) {
  const lapack_int tiles = T.count();
  TileList phase;
  for (lapack_int k = 0; k < tiles; ++k) {
    phase.clear();
    for (lapack_int m = k + 1; m < tiles; ++m) phase.emplace_back(m, k);
    run_phase(phase, threads, [&](lapack_int m, lapack_int) {
      cblas_dtrsm(CblasColMajor, CblasRight, CblasLower, CblasNoTrans, CblasNonUnit, T.side(m), T.side(k), -1.0,
                  T.at(k, k), T.lda, T.at(m, k), T.lda);
    });
    phase.clear();
    for (lapack_int m = k + 1; m < tiles; ++m)
      for (lapack_int j = 0; j < k; ++j) phase.emplace_back(m, j);
    run_phase(phase, threads, [&](lapack_int m, lapack_int j) {
      cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, T.side(m), T.side(j), T.side(k), 1.0, T.at(m, k),
                  T.lda, T.at(k, j), T.lda, 1.0, T.at(m, j), T.lda);
    });
    phase.clear();
    for (lapack_int j = 0; j < k; ++j) phase.emplace_back(k, j);
    run_phase(phase, threads, [&](lapack_int, lapack_int j) {
      cblas_dtrsm(CblasColMajor, CblasLeft, CblasLower, CblasNoTrans, CblasNonUnit, T.side(k), T.side(j), 1.0,
                  T.at(k, k), T.lda, T.at(k, j), T.lda);
    });
    const lapack_int info = LAPACKE_dtrtri_work(LAPACK_COL_MAJOR, 'L', 'N', T.side(k), T.at(k, k), T.lda);
    if (info != 0) return info + k * T.size;
  }
  return 0;
}

// U <- the lower triangle of U^T U for the lower triangular U, tile by tile:
// at step k, row k of tiles adds its products to the tiles above it, then is
// multiplied by the diagonal tile's transpose, and the diagonal tile becomes
// U_kk^T U_kk (LAPACK lauum).
void tiled_lauum_lower(const Tiles& T, int threads) {
  const lapack_int tiles = T.count();
  TileList phase;
  for (lapack_int k = 0; k < tiles; ++k) {
    phase.clear();
    for (lapack_int j = 0; j < k; ++j)
      for (lapack_int m = j; m < k; ++m) phase.emplace_back(m, j);
    run_phase(phase, threads, [&](lapack_int m, lapack_int j) {
      if (m == j)
        cblas_dsyrk(CblasColMajor, CblasLower, CblasTrans, T.side(j), T.side(k), 1.0, T.at(k, j), T.lda, 1.0,
                    T.at(j, j), T.lda);
      else
        cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, T.side(m), T.side(j), T.side(k), 1.0, T.at(k, m),
                    T.lda, T.at(k, j), T.lda, 1.0, T.at(m, j), T.lda);
    });
    phase.clear();
    for (lapack_int j = 0; j < k; ++j) phase.emplace_back(k, j);
    run_phase(phase, threads, [&](lapack_int, lapack_int j) {
      cblas_dtrmm(CblasColMajor, CblasLeft, CblasLower, CblasTrans, CblasNonUnit, T.side(k), T.side(j), 1.0,
                  T.at(k, k), T.lda, T.at(k, j), T.lda);
    });
    LAPACKE_dlauum_work(LAPACK_COL_MAJOR, 'L', T.side(k), T.at(k, k), T.lda);
  }
}

}  // namespace

bool cholesky_in_place(Eigen::MatrixXd& K, int threads) {
  const lapack_int n = static_cast<lapack_int>(K.rows());
  if (n < kTiledFrom) return LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', n, K.data(), n) == 0;
  return tiled_potrf_lower(Tiles{K.data(), n, n, kTile}, threads) == 0;
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

bool cholesky_inverse_in_place(Eigen::MatrixXd& L, int threads) {
  const lapack_int n = static_cast<lapack_int>(L.rows());
  if (n < kTiledFrom) return LAPACKE_dpotri_work(LAPACK_COL_MAJOR, 'L', n, L.data(), n) == 0;
  const Tiles T{L.data(), n, n, kTile};
  if (tiled_trtri_lower(T, threads) != 0) return false;
  tiled_lauum_lower(T, threads);
  return true;
}

}  // namespace gipdyn
