#pragma once
// The one search over log-hyperparameters that every estimator learned by
// marginal likelihood uses: several starts, each a run of minimize()
// (optim/optimizer.hpp), screened by one rule, the lowest objective kept.
// Per-joint GP fits (training.hpp) and LIP (estimators/lagrangian_estimator.hpp)
// are adapters of it: they give the start points, and per start an objective
// (with its own workspace, since starts may run side by side) and a progress
// callback.
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/optim/optimizer.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

// How an estimator learned by marginal likelihood searches its
// hyperparameters, whatever its model: the settings a user chooses for the
// per-joint GPs (TrainOptions::search, training.hpp) and for LIP
// (LagrangianOptions::search), and that a teacher inherits from its student
// (TeacherOptions::teacher_search). Each estimator derives from them the
// SearchOptions of its runs below.
struct SearchSettings {
  OptimizerOptions optimizer;
  // A run has converged when the projected |dNLL/dlog theta|_inf at its best
  // point is at most this times the number of rows (the NLL and its gradient
  // grow with the rows); it sets OptimizerOptions::gradient_tolerance.
  // docs/results/training.md measures how far short of the optimum looser tolerances stop.
  double gradient_tolerance_per_row = 1e-5;
  // Restarts from perturbed starts (log-parameters + N(0, restart_spread^2)),
  // seeded; the run with the lowest NLL is kept (like scikit-learn's n_restarts_optimizer).
  // Unset: the estimator's own (EstimatorSpec::restarts and restart_spread,
  // filled in by EstimatorOptions), since how many optima an NLL has depends on
  // the model; a search outside the estimator table: kDefaultRestarts at
  // kDefaultRestartSpread.
  std::optional<int> restarts;
  std::optional<double> restart_spread;
  static constexpr int kDefaultRestarts = 0;
  static constexpr double kDefaultRestartSpread = 1.0;
  int restart_count() const { return restarts.value_or(kDefaultRestarts); }
  double restart_spread_or_default() const { return restart_spread.value_or(kDefaultRestartSpread); }
  std::uint64_t seed = 0;
  // Screening of the starts (SearchOptions::screening_evaluations): lip's
  // starts (three starting noises, plus restarts) and a GP joint's restarts
  // first run for at most this many NLL evaluations each; only the one with
  // the lowest NLL then continues to convergence (a GP joint's unperturbed
  // start goes on too, so that its restarts never end above it). docs/results/training.md measures
  // how close the leader at this budget ends to the best of the starts run to
  // the end. 0: every start runs to convergence. Unset: the estimator's own
  // (EstimatorSpec::start_screening_evaluations); outside the estimator table,
  // kDefaultStartScreening.
  std::optional<int> start_screening_evaluations;
  static constexpr int kDefaultStartScreening = 60;
  int start_screening_or_default() const { return start_screening_evaluations.value_or(kDefaultStartScreening); }
  // With more rows than this, the hyperparameters are searched on a
  // constant-step subsample of this many rows, and the model is then
  // conditioned on every row: one O(N^3) factorisation (or one O(N M^2) pass
  // of a sparse GP) instead of one per evaluation. How a GP learns from 10^6
  // rows in minutes (docs/results/training.md). 0 (the default): search on all rows.
  int hyperparameter_rows = 0;
  // Noise variance, relative to the variance of the scaled output: its start and its floor.
  double initial_noise_fraction = 1e-2;
  double min_noise_fraction = 1e-8;
  JitterPolicy jitter;
  // Computed at once: a GP's joints, or LIP's starts; 0: all, as memory
  // permits. More than the cores share them, so that no core waits while the
  // longest finishes (docs/results/training.md); the results do not depend on it.
  int threads = 0;

  // Throws gipdyn::Error naming the bad field (e.g. "SearchSettings::restarts must be >= 0").
  void validate() const;
};

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
  // The first this many starts go on past the screening budget beside the
  // leader, whatever their objective there. A GP keeps its unperturbed start
  // (1), so that restarts can only lower the kept objective: a start that
  // trails at the budget may still end lowest where the objective has several
  // optima. 0: only the leader goes on.
  int continued_starts = 0;
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

// SearchSettings::restarts start points perturbed from `from`: each
// log-parameter plus N(0, restart_spread^2), drawn in order from a generator
// seeded with seed * 1000003 + stream. Estimators give their own stream (a GP
// its joint), so that their restarts differ under one seed.
std::vector<Eigen::VectorXd> restart_points(const Eigen::VectorXd& from, const SearchSettings& settings,
                                            std::uint64_t stream);

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
