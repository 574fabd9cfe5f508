#pragma once
// The --data option of the commands that read a robot log: a CSV whose columns
// are found by name, or, with --mat-variable, a matrix of a MATLAB file whose
// columns are q, qd, qdd (and tau) by position.
#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <string>

#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/io/log_columns.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn::cli {

// Adds --data, described by `csv_help` (what the CSV holds), --mat-variable and --columns (what the
// CSV calls gipdyn's columns, parse_log_columns); read_robot_log (gipdyn/io/mat_dataset.hpp) reads them.
void add_data_option(CLI::App& app, std::string& path, std::string& mat_variable, std::string& columns,
                     const std::string& csv_help);

// The --columns option alone, for commands that read a log without add_data_option.
void add_columns_option(CLI::App& app, std::string& columns);

// The joint types given with --joints (warned about where the log's .json sidecar records others),
// else those the sidecar records (sidecar_joint_types: simulate writes them), else those of the
// --robot a model-based estimator is given (`robot`, empty if none), which must have as many joints
// as the CSV's columns name. Without any, an error that says how many joints the CSV's columns name
// and how to write their types: the file cannot tell revolute from prismatic.
JointTypes joint_types_option(const std::string& joints, const std::string& path, const std::string& mat_variable,
                              const std::string& robot = "", const LogColumns& columns = {});

// Warns, on stderr, when states of the log at `path` lie well outside the inputs an exact GP model
// was trained on (extrapolation_warning, gipdyn/training_data.hpp); silent for other models.
void warn_about_extrapolation(const Estimator& estimator, const Eigen::MatrixXd& X, const std::string& path);

}  // namespace gipdyn::cli
