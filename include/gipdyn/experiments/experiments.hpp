#pragma once
// The paper's experiments (METHOD.md §8), each writing CSV, a Markdown summary
// and PNG plots into one output folder. Every experiment records each finished
// unit of work (a run of an estimator, a training size, a split) as soon as it
// is done; restarted with the same settings and folder, it skips those units.
// config.json in the folder holds the settings; a restart with other settings
// is refused rather than mixed in (except --runs, so an experiment can be extended).
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gipdyn/estimators/estimator.hpp"

namespace gipdyn {

// One line of progress: which unit, which estimator, elapsed time and estimate of time left.
using ExperimentCallback = std::function<void(const std::string&)>;

struct ExperimentOutcome {
  int units_done = 0;      // fitted in this invocation
  int units_skipped = 0;   // already recorded by an earlier invocation
  int units_failed = 0;    // fits that failed (recorded as nan, with the reason in the log)
  std::vector<std::string> files;     // what was written
  std::vector<std::string> warnings;  // e.g. plots that could not be drawn
};

// E1: accuracy under model bias.
struct AccuracyConfig {
  std::string robot = "scara";  // nominal robot: scara, ur10, URDF or JSON
  int runs = 20;
  int samples = 2000;       // per trajectory (train and test)
  std::uint64_t seed = 0;
  double dt = 0.01;
  double noise_std = 0.01;
  std::vector<std::string> estimators{"fe", "pp", "sp", "gip", "rbf", "nn"};
  EstimatorOptions base;    // options of every estimator (name and robot prior are set per fit)
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
ExperimentOutcome run_accuracy_experiment(const AccuracyConfig& config, const ExperimentCallback& progress = {});

// E2: data efficiency (no model bias).
struct DataEfficiencyConfig {
  std::string robot = "scara";
  int train_samples = 4000, test_samples = 4000;
  std::vector<int> sizes{100, 200, 500, 1000, 2000, 4000};
  int runs = 1;
  std::uint64_t seed = 0;
  double dt = 0.01;
  double noise_std = 0.01;
  std::vector<std::string> estimators{"gip", "rbf", "nn", "pp"};
  EstimatorOptions base;
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
ExperimentOutcome run_data_efficiency_experiment(const DataEfficiencyConfig& config,
                                                 const ExperimentCallback& progress = {});

// E3: a real robot log, split into contiguous train and test row ranges, or
// into alternating blocks of rows.
struct RealRobotConfig {
  std::string data;          // CSV of the documented layout, or a .mat file with mat_variable
  std::string mat_variable;  // columns q, qd, qdd, tau by position
  std::string joints;
  // 1-based inclusive data-row ranges (first, last).
  std::pair<long, long> train_rows{0, 0}, test_rows{0, 0};
  // Instead of the ranges: blocks of this many rows over the whole log, the
  // first, third, ... for training and the second, fourth, ... for testing.
  int alternate_blocks = 0;
  int max_train = 4000;      // GP estimators: constant-step subsample of the training rows
  int nn_max_train = 0;      // nn: the same kind of subsample (0: every training row, as the paper)
  int plot_window = 1000;    // test rows shown in the torque-over-time plot
  std::vector<std::string> estimators{"gip", "gip-friction", "rbf", "nn"};
  std::string robot;         // nominal robot for fe, pp, sp ("" : those are not run)
  bool robot_friction = false;
  EstimatorOptions base;
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
// The reference protocols of ../shared/data/README.md: "ur10" fills rows, robot and estimators.
void apply_protocol(const std::string& protocol, RealRobotConfig& config);
ExperimentOutcome run_real_robot_experiment(const RealRobotConfig& config, const ExperimentCallback& progress = {});

// "1-6340" -> {1, 6340}; throws gipdyn::Error with the expected form.
std::pair<long, long> parse_row_range(const std::string& text, const std::string& option);

}  // namespace gipdyn
