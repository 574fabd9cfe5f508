#pragma once
// Minimisers for the log-hyperparameters: L-BFGS (NLopt, the default) and Adam
// (as in the paper). Both return the best point they evaluated and a status
// with a message; they never throw for numerical trouble.
#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

enum class OptimizerKind { Lbfgs, Adam };
OptimizerKind parse_optimizer(const std::string& name);  // "lbfgs" | "adam"
std::string to_string(OptimizerKind kind);

struct OptimizerOptions {
  OptimizerKind kind = OptimizerKind::Lbfgs;
  // A safety cap: the stopping rules below should end a run long before it.
  int max_iterations = 1000;           // L-BFGS: objective evaluations; Adam: steps
  double f_relative_tolerance = 1e-9;  // stop when an iteration changes f by <= tol * |f|
  double gradient_tolerance = 1e-5;    // stop when the best point's projected max |grad| is <= it
  // Converged on a plateau: stop when the best objective has fallen by less
  // than plateau_decrease over the last plateau_evaluations evaluations. For a
  // negative log likelihood the decrease is a log likelihood ratio, so a
  // plateau of 0.1 is hyperparameters that the data tell apart by less than a
  // factor e^0.1 = 1.1. 0 evaluations: off (the default).
  int plateau_evaluations = 0;
  double plateau_decrease = 0.0;
  // L-BFGS: correction pairs kept (NLopt's vector storage). About the number of
  // hyperparameters of a GIP kernel (38 for a SCARA), whose NLL is badly scaled
  // between them: NLopt's usual 10 hold too little curvature for it, and the
  // search creeps (docs/results/training.md compares memories).
  int lbfgs_memory = 40;
  double adam_learning_rate = 0.01;
  double adam_beta1 = 0.9;
  double adam_beta2 = 0.999;
  int adam_patience = 20;  // Adam: steps without relative improvement before stopping
  Eigen::VectorXd lower_bounds;  // optional box bounds (empty: none)
  Eigen::VectorXd upper_bounds;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

// f(x, grad, want_grad) -> ok. On !ok the point is treated as infeasible.
using Objective = std::function<bool(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& grad)>;

struct OptimizerResult {
  enum class Status { Converged, MaxIterations, Stalled, Failed };
  Status status = Status::Failed;
  std::string message;
  Eigen::VectorXd x;  // best point evaluated
  double f = 0.0;
  double grad_norm = 0.0;  // projected |grad|_inf at x
  int evaluations = 0;
  bool usable() const { return status != Status::Failed; }
};
std::string to_string(OptimizerResult::Status status);  // converged, max-iter, stalled, failed
OptimizerResult::Status parse_optimizer_status(const std::string& name);  // the inverse; throws gipdyn::Error

// The best of several runs from different starts (restarts), by objective.
struct BestOfStarts {
  // The lowest-objective usable run so far; while none is usable, a failed
  // result carrying the last run's message.
  OptimizerResult kept;
  std::vector<double> objectives;  // one per run, NaN where a run failed
  void add(const OptimizerResult& run);
  bool found() const { return found_; }

 private:
  bool found_ = false;
};

// Asked before every evaluation after the first, with the evaluations made
// and the best objective so far: false ends the run there, with status
// MaxIterations, as at the evaluation cap. How several starts run side by
// side and only the best goes on (LagrangianEstimator's screening); it may
// block until the other starts catch up.
using EvaluationGate = std::function<bool(int evaluations, double best_objective)>;

// progress gets one event after every accepted evaluation (iteration, objective,
// projected |grad|_inf); the caller's fields of the event are left empty.
OptimizerResult minimize(const Objective& objective, const Eigen::VectorXd& x0, const OptimizerOptions& options,
                         const ProgressCallback& progress = {}, const EvaluationGate& gate = {});

}  // namespace gipdyn
