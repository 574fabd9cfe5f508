#pragma once
// The --data option of the commands that read a robot log: a CSV whose columns
// are found by name, or, with --mat-variable, a matrix of a MATLAB file whose
// columns are q, qd, qdd (and tau) by position.
#include <CLI/CLI.hpp>
#include <string>

#include "gipdyn/io/dataset.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn::cli {

// Adds --data, described by `csv_help` (what the CSV holds), and --mat-variable.
void add_data_option(CLI::App& app, std::string& path, std::string& mat_variable, const std::string& csv_help);

// The CSV, or the .mat file's variable when mat_variable is set. joints_owner as in read_dataset:
// where fixed joint types come from.
Dataset read_data_option(const std::string& path, const std::string& mat_variable, const JointTypes& joints,
                         bool require_tau, const std::string& joints_owner = "");

}  // namespace gipdyn::cli
