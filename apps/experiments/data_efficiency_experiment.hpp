#pragma once
// E2 (docs/results/paper-experiments.md): GMSE against the number of training samples, no model bias.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

// E2: data efficiency (no model bias).
struct DataEfficiencyConfig {
  std::string robot = "scara";
  int train_samples = 4000, test_samples = 4000;
  std::vector<int> sizes{100, 200, 500, 1000, 2000, 4000};
  int runs = 1;
  std::uint64_t seed = 0;
  double dt = 0.01;
  double noise_std = 0.01;
  std::vector<std::string> estimators = paper_data_efficiency_estimators();
  EstimatorOptions base;
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
ExperimentOutcome run_data_efficiency_experiment(const DataEfficiencyConfig& config,
                                                 const ProgressCallback& progress = {});

}  // namespace gipdyn
