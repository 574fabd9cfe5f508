#pragma once
// Training an inverse dynamics model: one GP per joint, hyperparameters by
// maximum marginal likelihood, joints trained in parallel.
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "gipdyn/blas_threads.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/hyperparameter_prior.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/optim/optimizer.hpp"

namespace gipdyn {

struct TrainOptions {
  std::string kernel = "gip";
  // The nominal robot for model-based kernels (pp, sp); required by them, ignored by the others.
  RobotPrior robot_prior;
  OptimizerOptions optimizer;
  OutputScaling scaling = OutputScaling::Standardize;
  // Prior mean of every joint's GP (on the scaled output), trained with the kernel.
  MeanKind mean = MeanKind::Zero;
  // Restarts from perturbed starts (log-parameters + N(0, restart_spread^2)),
  // seeded; the run with the lowest NLL is kept (like scikit-learn's n_restarts_optimizer).
  int restarts = 0;
  double restart_spread = 1.0;
  std::uint64_t seed = 0;
  // Noise variance, relative to the variance of the scaled output: its start and its floor.
  double initial_noise_fraction = 1e-2;
  double min_noise_fraction = 1e-8;
  int threads = 0;  // 0: min(hardware threads, joints)
  // Off: maximum marginal likelihood. On: MAP with log-normal priors centred on the data-driven start.
  HyperparameterPrior prior;
  bool keep_factor = true;  // keep Cholesky factors so the model can give variances
  JitterPolicy jitter;

  // Throws gipdyn::Error naming the bad option.
  void validate() const;
};

struct TrainingProgress {
  int joint = 0;     // 0-based
  int restart = 0;   // 0 = the data-driven start
  int iteration = 0;
  double nll = 0.0;
  double grad_norm = 0.0;
  double seconds = 0.0;
  bool finished = false;  // the joint's final report
  std::string message;
};
// Called from worker threads: the callback must be thread-safe.
using TrainingCallback = std::function<void(const TrainingProgress&)>;

struct JointReport {
  int joint = 0;
  double nll = 0.0;
  std::vector<double> restart_nlls;
  int evaluations = 0;
  double seconds = 0.0;
  double jitter = 0.0;
  OptimizerResult::Status status = OptimizerResult::Status::Failed;
  std::string message;
};

struct TrainResult {
  bool ok = false;
  std::string message;  // on failure: which joint and why
  InverseDynamicsModel model;
  std::vector<JointReport> joints;
};

constexpr int kMinTrainingRows = 5;

// Checks shapes (X: N x 3n, Y: N x n), finiteness and N >= kMinTrainingRows;
// throws gipdyn::Error with the first problem found.
void validate_training_data(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints);

TrainResult train_model(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                        const TrainOptions& options, const TrainingCallback& progress = {});

// Rows floor(k rows / count), k = 0..count-1: `count` rows with a constant
// (possibly fractional) step over the whole range, as the paper subsampled the
// UR10 data. count >= rows keeps everything.
std::vector<Eigen::Index> constant_step_indices(Eigen::Index rows, Eigen::Index count);

}  // namespace gipdyn
