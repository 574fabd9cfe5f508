#pragma once
// Where an exact GP's negative log marginal likelihood, its gradient and its
// weights alpha = K^-1 y are computed on all training rows. Training uses this
// process's LAPACK unless TrainOptions::nll_backend names another backend: the
// MPI + ScaLAPACK one in distributed/distributed_nll.hpp spreads the N x N
// matrix and its factorisation over processes.
#include <Eigen/Dense>
#include <string>
#include <utility>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/exact_gp.hpp"

namespace gipdyn {

class NllBackend {
 public:
  virtual ~NllBackend() = default;
  // As evaluate_nll() (zero prior mean); alpha, when not null, receives K^-1 y.
  // A backend that spans processes is collective: every process calls it with
  // the same arguments, in the same order.
  virtual NllEvaluation evaluate(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                                 const Eigen::VectorXd& y, bool with_gradient, Eigen::VectorXd* alpha,
                                 const JitterPolicy& jitter) = 0;
  // Called once by train_model before any evaluation, with the training
  // features and targets (one column per joint). Throws
  // gipdyn::Error when the backend cannot hold a problem of this size, or (for
  // processes) when they disagree on the data. Collective like evaluate().
  virtual void plan(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& Y) = 0;
  // One line for reports, e.g. "2 MPI processes, a 1 x 2 grid of 64-row blocks".
  virtual std::string describe() const = 0;
};

// The exact NLL in this process (LAPACK), with the prior mean's coefficients
// profiled out (evaluate_profiled_nll): the backend of a training without
// TrainOptions::nll_backend. It owns its workspace, so each thread that
// evaluates needs its own; X, the raw inputs the mean is a function of, must
// outlive it.
class InProcessNll : public NllBackend {
 public:
  InProcessNll(MeanFunction mean, const Eigen::MatrixXd& X) : mean_(std::move(mean)), X_(X) {}
  // alpha, when not null, receives K^-1 (y - m(X)).
  NllEvaluation evaluate(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                         const Eigen::VectorXd& y, bool with_gradient, Eigen::VectorXd* alpha,
                         const JitterPolicy& jitter) override;
  // Nothing to plan: train_model checks this process's memory itself.
  void plan(const Eigen::MatrixXd&, const Eigen::MatrixXd&) override {}
  std::string describe() const override { return "this process"; }

 private:
  MeanFunction mean_;
  const Eigen::MatrixXd& X_;
  GpWorkspace ws_;
};

}  // namespace gipdyn
