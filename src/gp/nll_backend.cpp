#include "gipdyn/gp/nll_backend.hpp"

namespace gipdyn {

NllEvaluation InProcessNll::evaluate(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                                     const Eigen::VectorXd& y, bool with_gradient, Eigen::VectorXd* alpha,
                                     const JitterPolicy& jitter) {
  NllEvaluation e = evaluate_profiled_nll(kernel, log_noise_variance, mean_, X_, Z, y, with_gradient, ws_, nullptr,
                                          jitter);
  if (alpha && e.ok()) *alpha = ws_.alpha;
  return e;
}

}  // namespace gipdyn
