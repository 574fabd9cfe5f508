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
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/optim/optimizer.hpp"
#include "gipdyn/progress.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

// The advice train_model gives when the rows do not fit in memory; front ends
// rename it to their own way of choosing fewer rows.
extern const char* const kFewerRowsAdvice;

// What the hyperparameters of a sparse GP learned on a subsample
// (TrainOptions::hyperparameter_rows) minimise.
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

struct TrainOptions {
  std::string kernel = default_kernel_name();  // a name of kernel_table() (kernels/kernel_factory.hpp)
  // The nominal robot for model-based kernels (pp, sp); required by them, ignored by the others.
  RobotPrior robot_prior;
  OptimizerOptions optimizer;
  OutputScaling scaling = OutputScaling::Standardize;
  // Prior mean of every joint's GP (on the scaled output), trained with the kernel.
  MeanKind mean = MeanKind::Zero;
  // Restarts from perturbed starts (log-parameters + N(0, restart_spread^2)),
  // seeded; the run with the lowest NLL is kept (like scikit-learn's n_restarts_optimizer).
  // With a warm start they run on the subsample, where they are cheap.
  int restarts = 0;
  double restart_spread = 1.0;
  std::uint64_t seed = 0;
  // Warm start: with at least twice this many rows, optimise first on a
  // constant-step subsample of this many rows (every start and restart there,
  // each evaluation (rows/N)^3 of the cost), then continue on all rows from the
  // best subsample optimum. 0 (the default): optimise on all rows from the
  // start. Opt-in: the subsample's optimum need not lead to the full data's
  // best one (docs/training.md measures both).
  int warm_start_rows = 0;
  // Sparse GP (gp/sparse_gp.hpp): with M > 0, each joint is conditioned on M
  // inducing rows chosen among the training rows (greedy variance under the
  // first joint's initial kernel, shared by every joint), and its
  // hyperparameters minimise Titsias' bound, O(N M^2) per evaluation instead of
  // O(N^3). The model then holds the inducing rows only. 0: exact GP.
  int inducing_points = 0;
  // With more rows than this, the hyperparameters are optimised on a
  // constant-step subsample of this many rows (the NLL, or the sparse bound on
  // the same inducing rows), and the model is then conditioned on every row:
  // one O(N^3) factorisation, or one O(N M^2) pass with inducing points, instead
  // of one per evaluation. How a sparse GP learns from 10^6 rows in minutes
  // (docs/training.md). 0 (the default): optimise on all rows.
  int hyperparameter_rows = 0;
  // With inducing points and hyperparameter_rows: the objective on the
  // subsample. Exact needs hyperparameter_rows (the exact NLL of every row is
  // what a sparse GP avoids); without inducing points the objective is always exact.
  HyperparameterObjective hyperparameter_objective = HyperparameterObjective::SparseBound;
  // A joint's optimisation has converged when the projected |dNLL/dlog theta|_inf
  // at its best point is at most this times the number of rows (the NLL and its
  // gradient grow with the rows); it sets OptimizerOptions::gradient_tolerance.
  // docs/training.md measures how far short of the optimum looser tolerances stop.
  double gradient_tolerance_per_row = 1e-5;
  // Noise variance, relative to the variance of the scaled output: its start and its floor.
  double initial_noise_fraction = 1e-2;
  double min_noise_fraction = 1e-8;
  // Per joint, a floor on the noise's standard deviation in the torque's units
  // (N m, N), where the targets are known to be no more precise than that: a
  // teacher's torques, known to its residual on the log (estimators/teacher.hpp).
  // Below it, an expressive kernel fitted on a subsample can interpolate the
  // targets (docs/training.md). Empty: min_noise_fraction alone; else one
  // value >= 0 per joint.
  Eigen::VectorXd noise_std_floor;
  // lip (and a lip teacher): the joints are ordered from the base to the tip
  // of a serial chain, as in every URDF chain, DH table and robot log, so the
  // inertia matrix's entry ab depends only on the joints after min(a, b), and
  // the kernel says so (LagrangianKernel's serial_chain, docs/method.md
  // section 11). Off: every entry may depend on every joint (the LIP paper's
  // kernel), for joints in another order.
  bool serial_chain = true;
  // Screening of the starts (SearchOptions::screening_evaluations,
  // hyperparameter_search.hpp): lip's starts (three starting noises, plus
  // restarts) and a GP joint's restarts first run for at most this many NLL
  // evaluations each; only the one with the lowest NLL then continues to
  // convergence. docs/training.md measures how close the leader at this
  // budget ends to the best of the starts run to the end.
  // 0: every start runs to convergence.
  int start_screening_evaluations = 60;
  // Per joint, the starting point [kernel log-params, log noise variance] instead
  // of the data-driven start (clamped into the optimiser's bounds); empty: data-driven.
  // refit_model fills it with a model's current hyperparameters.
  std::vector<Eigen::VectorXd> initial_log_params;
  // Joints trained at once; 0: every joint, as memory permits. More joints than
  // cores share them, so that no core waits while the longest joint finishes
  // (docs/training.md); the results do not depend on it.
  int threads = 0;
  // Off: maximum marginal likelihood. On: MAP with log-normal priors centred on the data-driven start.
  HyperparameterPrior prior;
  bool keep_factor = true;  // keep Cholesky factors so the model can give variances
  JitterPolicy jitter;
  // Null: every NLL on all rows, and the final fit, in this process. Otherwise
  // they go to this backend (e.g. DistributedNll, MPI + ScaLAPACK): the joints
  // are then trained one after another, every process of the backend calls
  // train_model with the same arguments, and warm starts stay in process. It
  // needs the exact GP (inducing_points 0), a zero mean and keep_factor off
  // (the factor is spread over the processes; a loaded model recomputes it).
  std::shared_ptr<NllBackend> nll_backend;

  // Throws gipdyn::Error naming the bad field (e.g. "TrainOptions::restarts must be >= 0").
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
// threads TrainOptions::threads asks for (one per joint for 0), fewer where
// memory is short (docs/training.md), one with a backend (its evaluations are
// collective). Front ends use it to estimate a fit's time.
int joints_trained_at_once(const TrainOptions& options, Eigen::Index rows, int joints);

// Per joint, a model's [kernel log-parameters, log noise variance]: the
// TrainOptions::initial_log_params that start a training where this model's
// ended (refit_model; warm starts between similar data sets).
std::vector<Eigen::VectorXd> learned_log_params(const InverseDynamicsModel& model);

// Re-optimises every joint's hyperparameters on the model's own rows
// (training_inputs(), training_targets()), starting from its current ones:
// the periodic refit of online learning, for when the robot has changed more
// than new rows at old hyperparameters can express. The kernel, nominal robot,
// output scaling and mean come from the model; the optimiser settings, restarts
// and threads from `options`. Throws gipdyn::Error for a sparse model (it keeps
// no training rows) and whatever train_model throws.
TrainResult refit_model(const InverseDynamicsModel& model, const TrainOptions& options,
                        const ProgressCallback& progress = {});

}  // namespace gipdyn
