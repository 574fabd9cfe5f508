#pragma once
// The one search over log-hyperparameters that every estimator learned by
// marginal likelihood uses: several starts, each a run of minimize()
// (optim/optimizer.hpp), screened by one rule, the lowest objective kept.
// Per-joint GP fits (training.hpp) and LIP (estimators/lagrangian_estimator.hpp)
// are adapters of it: they give the start points, and per start an objective
// (with its own workspace, since starts may run side by side) and a progress
// callback.
#include <Eigen/Dense>
#include <functional>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/optim/optimizer.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

struct SearchOptions {
  // Every run's optimiser, with the objective's bounds and gradient tolerance.
  OptimizerOptions optimizer;
  // Screening: every start first runs for at most this many evaluations, and
  // only the one with the lowest objective there (the first of equals) goes
  // on. It depends on the starts' objectives at the budget alone, not on
  // timing, so the kept optimum does not depend on the threads. It keeps every
  // start in flight, so it applies only where they all fit in memory
  // (bytes_per_start) and the objective may run on several threads
  // (concurrent_objectives). 0, one start, or a budget at or above the
  // optimiser's evaluation cap: every start runs to convergence.
  int screening_evaluations = 0;
  // Evaluations computed at once; the other starts in flight wait for a slot.
  // 1 where the search is itself one task of a parallel loop (a GP's joints).
  int threads = 1;
  // Memory one start in flight holds (its workspace); 0: not limiting.
  double bytes_per_start = 0.0;
  // Off where every evaluation must come in the same order on every process
  // (a distributed likelihood's collective calls): the starts then run one
  // after another and are not screened.
  bool concurrent_objectives = true;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

struct SearchResult {
  BestOfStarts best;              // the kept run, and one objective per start (NaN where a start failed)
  int evaluations = 0;            // over every start
  int screening_evaluations = 0;  // the budget, where screening stopped a start; else 0
};

// Start r's objective and progress callback (may be empty).
using StartObjective = std::function<Objective(int start)>;
using StartProgress = std::function<ProgressCallback(int start)>;

// Runs minimize() from every start point (each clamped into the optimiser's
// bounds by the caller) under the options' screening and threads; the result
// keeps the lowest objective. Exceptions of an objective are rethrown once
// every start has stopped.
SearchResult search_hyperparameters(const std::vector<Eigen::VectorXd>& starts, const StartObjective& objective_for,
                                    const SearchOptions& options, const StartProgress& progress_for = {});

}  // namespace gipdyn
