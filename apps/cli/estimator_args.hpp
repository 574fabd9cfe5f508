#pragma once
// The estimator options shared by `train` and `experiment`: which estimator,
// its optimiser, the nominal robot of model-based estimators, the network's shape.
#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>

#include "gipdyn/estimators/fit_estimator.hpp"

namespace gipdyn::cli {

struct EstimatorArgs {
  std::string optimizer = "lbfgs", scaling = "standardize", mean = "zero", robot, nn_hidden, prior = "none";
  double prior_width = 2.0;
  // Library defaults, so that --help shows what the library does.
  int max_iter = OptimizerOptions{}.max_iterations, lbfgs_memory = OptimizerOptions{}.lbfgs_memory;
  int threads = 0;
  // Unset where not given: the model's own (EstimatorSpec::restarts, start_screening_evaluations).
  std::optional<int> restarts, start_screening;
  int warm_start_rows = GpOptions{}.warm_start_rows, inducing = SparseOptions{}.inducing_points;
  int hyperparameter_rows = SearchSettings{}.hyperparameter_rows;
  std::string hyperparameter_objective = to_string(SparseOptions{}.hyperparameter_objective);
  double gradient_tolerance = SearchSettings{}.gradient_tolerance_per_row;
  std::uint64_t seed = 0;
  double min_noise = 1e-8, learning_rate = 0.01;
  bool robot_friction = false;
  bool no_serial_chain = false;
  NeuralNetworkOptions nn;
  ChainIdentificationOptions chain;

  // GP, robot and network options (not --model, whose help differs per command).
  void add_to(CLI::App& app, bool with_robot, bool with_seed = true);
  // Options for estimator `name`; loads --robot when given. Throws gipdyn::Error
  // for text it cannot parse; the values are checked where they are used.
  EstimatorOptions build(const std::string& name) const;
  // The same on top of `base` (a preset): only the options given on `app`'s
  // command line replace base's values (the estimator name when given_name).
  EstimatorOptions build_over(const EstimatorOptions& base, const CLI::App& app, const std::string& name,
                              bool given_name) const;
  RobotPrior robot_prior() const;

 private:
  EstimatorOptions overlay(EstimatorOptions o, const CLI::App* app) const;
};

std::string estimator_list();  // "gip, gip-friction, ..., fe, nn"
// One line per estimator of the library's table: its name, what it is, whether it needs --robot.
std::string estimator_table_text();
// One clause per preset: "default (gip), real (gip-envelope+friction, at most 1000 rows)".
std::string preset_list();

// Headings of --help: each model's search settings under its own "Advanced"
// heading, after the options a user needs first (data, joints, model, output),
// so that those are not lost among forty.
inline const char* const kGpOptions = "Advanced: GP hyperparameter search (gip, rbf and the other GP kernels)";
inline const char* const kRobotOptions = "Model-based estimators (fe, pp, sp)";
inline const char* const kLipOptions = "Advanced: LIP search (lip, and the lip teacher)";
inline const char* const kNetworkOptions = "Advanced: neural network training (nn)";
inline const char* const kChainOptions = "Advanced: serial chain identified from the log (chain)";

}  // namespace gipdyn::cli
