#pragma once
// Training an inverse dynamics model: one GP per joint, hyperparameters by
// maximum marginal likelihood, joints trained in parallel.
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/hyperparameter_prior.hpp"
#include "gipdyn/gp/nll_backend.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/optim/optimizer.hpp"
#include "gipdyn/progress.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

// The advice train_model gives when the rows do not fit in memory; front ends
// rename it to their own way of choosing fewer rows.
extern const char* const kFewerRowsAdvice;

// What the hyperparameters of a sparse GP learned on a subsample
// (SearchSettings::hyperparameter_rows) minimise.
enum class HyperparameterObjective {
  // Titsias' bound on the model's inducing rows: the objective the model itself has.
  SparseBound,
  // The exact NLL of the subsample's rows, O(H^3) per evaluation: no bound
  // slack, so none of the bound's all-noise optima that the trace term creates
  // when the inducing rows cannot represent a joint (docs/method.md section 14).
  Exact,
};
std::string to_string(HyperparameterObjective o);
// "bound" or "exact"; throws gipdyn::Error naming the field otherwise.
HyperparameterObjective parse_hyperparameter_objective(const std::string& s);

// The GP of each joint beside its kernel: what a student's model is, which a
// teacher does not inherit.
struct GpOptions {
  OutputScaling scaling = OutputScaling::Standardize;
  // Prior mean of every joint's GP (on the scaled output), trained with the kernel.
  MeanKind mean = MeanKind::Zero;
  // Off: maximum marginal likelihood. On: MAP with log-normal priors centred on the data-driven start.
  HyperparameterPrior prior;
  // Per joint, a floor on the noise's standard deviation in the torque's units
  // (N m, N), where the targets are known to be no more precise than that: a
  // teacher's torques, known to its residual on the log (estimators/teacher.hpp).
  // Below it, an expressive kernel fitted on a subsample can interpolate the
  // targets (docs/results/training.md). Empty: SearchSettings::min_noise_fraction
  // alone; else one value >= 0 per joint.
  Eigen::VectorXd noise_std_floor;
  // Per joint, the starting point [kernel log-params, log noise variance] instead
  // of the data-driven start (clamped into the optimiser's bounds); empty: data-driven.
  // refit_model fills it with a model's current hyperparameters.
  std::vector<Eigen::VectorXd> initial_log_params;
  // Warm start: with at least twice this many rows, search first on a
  // constant-step subsample of this many rows (every start and restart there,
  // each evaluation (rows/N)^3 of the cost), then continue on all rows from the
  // best subsample optimum. 0 (the default): search on all rows from the
  // start. Opt-in: the subsample's optimum need not lead to the full data's
  // best one (docs/results/training.md measures both).
  int warm_start_rows = 0;
  bool keep_factor = true;  // keep Cholesky factors so the model can give variances

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

// A sparse GP (gp/sparse_gp.hpp) instead of the exact one.
struct SparseOptions {
  // With M > 0, each joint is conditioned on M inducing rows chosen among the
  // training rows (greedy variance under the first joint's initial kernel,
  // shared by every joint), and its hyperparameters minimise Titsias' bound,
  // O(N M^2) per evaluation instead of O(N^3). The model then holds the
  // inducing rows only. 0: exact GP.
  int inducing_points = 0;
  // With inducing points and SearchSettings::hyperparameter_rows: the
  // objective on the subsample. Exact needs hyperparameter_rows (the exact NLL
  // of every row is what a sparse GP avoids); without inducing points the
  // objective is always exact.
  HyperparameterObjective hyperparameter_objective = HyperparameterObjective::SparseBound;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

// train_model's options, by what they configure.
struct TrainOptions {
  std::string kernel = default_kernel_name();  // a name of kernel_table() (kernels/kernel_factory.hpp)
  // The nominal robot for model-based kernels (pp, sp); required by them, ignored by the others.
  RobotPrior robot_prior;
  SearchSettings search;  // how the hyperparameters are searched (hyperparameter_search.hpp)
  GpOptions gp;           // each joint's GP
  SparseOptions sparse;   // a sparse GP instead of the exact one
  // Where the likelihood is computed. Null: every NLL on all rows, and the
  // final fit, in this process. Otherwise they go to this backend (e.g.
  // DistributedNll, MPI + ScaLAPACK): the joints are then trained one after
  // another, every process of the backend calls train_model with the same
  // arguments, and warm starts stay in process. It needs the exact GP
  // (inducing_points 0), a zero mean and keep_factor off (the factor is spread
  // over the processes; a loaded model recomputes it).
  std::shared_ptr<NllBackend> nll_backend;

  // Each part's validate(), then the rules between parts; throws gipdyn::Error
  // naming the bad field (e.g. "SearchSettings::restarts must be between 0 and 1000").
  void validate() const;
};

struct TrainResult {
  FitReport report;            // status, per-joint reports; on failure the joint and the reason
  InverseDynamicsModel model;  // empty unless report.ok()
};

// The entry point: validates the options and the data once (throwing
// gipdyn::Error), then trains every joint. Numerical trouble does not throw: it
// is in TrainResult::report. progress gets the optimiser's events of every
// joint and restart, and one finished event per joint, from worker threads.
TrainResult train_model(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                        const TrainOptions& options, const ProgressCallback& progress = {});

// How many joints train_model trains at once on `rows` training rows: the
// threads SearchSettings::threads asks for (one per joint for 0), fewer where
// memory is short (docs/results/training.md), one with a backend (its evaluations are
// collective). Front ends use it to estimate a fit's time.
int joints_trained_at_once(const TrainOptions& options, Eigen::Index rows, int joints);

// Per joint, a model's [kernel log-parameters, log noise variance]: the
// GpOptions::initial_log_params that start a training where this model's
// ended (refit_model; warm starts between similar data sets).
std::vector<Eigen::VectorXd> learned_log_params(const InverseDynamicsModel& model);

// Where refit_model's search starts: the model's current hyperparameters (the
// periodic refit of online learning, where they are close), or the data-driven
// start of a new training (where an UpdateCheck shows they no longer fit: a
// search from them can stall where they left it).
enum class RefitStart { CurrentHyperparameters, DataDriven };

// Re-optimises every joint's hyperparameters on the model's own rows
// (training_inputs(), training_targets()), starting from `start`: for when the
// robot has changed more than new rows at old hyperparameters can express. The
// kernel, nominal robot, output scaling and mean come from the model; the
// optimiser settings, restarts and threads from `options`. Throws
// gipdyn::Error for a sparse model (it keeps no training rows) and whatever
// train_model throws.
TrainResult refit_model(const InverseDynamicsModel& model, const TrainOptions& options,
                        const ProgressCallback& progress = {},
                        RefitStart start = RefitStart::CurrentHyperparameters);

}  // namespace gipdyn
