#pragma once
// E3 (docs/results/paper-experiments.md, docs/results/real-robots.md): every estimator on a real robot
// log, split into train and test rows.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

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
  std::vector<std::string> estimators = default_compared_estimators(false);
  // Learning curve instead of one fit per estimator: every estimator on
  // `repeats` interleaved constant-step subsamples of each size (max_train and
  // nn_max_train are then not used).
  std::vector<int> sizes;
  int repeats = 3;
  // >= 0: clamp the test inputs (all but revolute positions) into the box of
  // each estimator's training rows, widened by this fraction of each column's range.
  double saturate = -1.0;
  std::string robot;         // nominal robot for fe, pp, sp ("" : those are not run)
  bool robot_friction = false;
  EstimatorOptions base;
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
// The reference protocols of ../shared/data/README.md: "ur10" fills rows, robot and estimators.
void apply_protocol(const std::string& protocol, RealRobotConfig& config);
// Runs the learning curve when config.sizes is set, the one-size comparison otherwise.
ExperimentOutcome run_real_robot_experiment(const RealRobotConfig& config, const ProgressCallback& progress = {});

// The log split as the config asks, for both kinds of run.
struct RealSplit {
  JointTypes joints;
  Dataset train, test;
  std::vector<Eigen::Index> test_rows;  // 0-based rows of the log
  std::string description;
  std::vector<std::string> warnings;
  RobotPrior prior;
};
RealSplit load_real_split(const RealRobotConfig& config);
// The test inputs an estimator trained on `trained_on` is asked about: saturated
// into its training box when config.saturate >= 0.
Eigen::MatrixXd test_inputs(const RealRobotConfig& config, const RealSplit& split, const Dataset& trained_on);
// nMSE against training size: learning_curve.csv, learning_curve.md, learning_curve.png.
ExperimentOutcome run_real_learning_curve(const RealRobotConfig& config, const ProgressCallback& progress = {});

}  // namespace gipdyn
