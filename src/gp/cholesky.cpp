#include "gipdyn/gp/cholesky.hpp"

#include <lapacke.h>

#include <cmath>
#include <sstream>

namespace gipdyn {

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
        return LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', n, K.data(), n) == 0;
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
