#pragma once
// Datasets from MATLAB files.
#include <string>

#include "gipdyn/io/dataset.hpp"

namespace gipdyn {

// A numeric 2-D variable of a MATLAB .mat file (v4, v5 or v7.3, read with
// matio) whose columns are positional: q (n), qd (n), qdd (n), then tau (n)
// when require_tau. Extra columns are ignored. Throws gipdyn::Error naming the
// file, the variable and the problem.
Dataset read_mat_dataset(const std::string& path, const std::string& variable, const JointTypes& joints,
                         bool require_tau);

// A robot log either way: the CSV at path (read_dataset; joints_owner and columns as there) when
// mat_variable is empty, else that variable of the .mat file at path, whose columns are positional
// (columns other than the default are refused there).
Dataset read_robot_log(const std::string& path, const std::string& mat_variable, const JointTypes& joints,
                       bool require_tau, const std::string& joints_owner = "", const LogColumns& columns = {});

}  // namespace gipdyn
