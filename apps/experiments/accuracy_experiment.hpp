#pragma once
// E1 (docs/results/paper-experiments.md): accuracy of every estimator under model bias, over
// Monte Carlo runs of a perturbed robot; nMSE per run, estimator and joint.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

// E1: accuracy under model bias.
struct AccuracyConfig {
  std::string robot = "scara";  // nominal robot: scara, ur10, URDF or JSON
  int runs = 20;
  int samples = 2000;       // per trajectory (train and test)
  std::uint64_t seed = 0;
  double dt = 0.01;
  double noise_std = 0.01;
  std::vector<std::string> estimators = paper_accuracy_estimators();
  EstimatorOptions base;    // options of every estimator (name and robot prior are set per fit)
  // GP estimators: runs after the first start from the first run's learned
  // hyperparameters (OUT/warm_starts.json) instead of the data-driven start.
  bool warm_start_runs = false;
  // Runs fitted at the same time, each fit on its share of the cores (unless
  // base.search.threads is set): no core waits for a fit's last joint or its
  // single-threaded network. The results do not depend on it; the wall time
  // and each fit's recorded seconds do.
  int concurrent_runs = 1;
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
ExperimentOutcome run_accuracy_experiment(const AccuracyConfig& config, const ProgressCallback& progress = {});

}  // namespace gipdyn
