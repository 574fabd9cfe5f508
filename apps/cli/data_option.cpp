#include "data_option.hpp"

#include "gipdyn/io/mat_dataset.hpp"

namespace gipdyn::cli {

void add_data_option(CLI::App& app, std::string& path, std::string& mat_variable, const std::string& csv_help) {
  app.add_option("--data", path, csv_help + ", or a .mat file with --mat-variable")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--mat-variable", mat_variable,
                 "--data is a MATLAB .mat file: read this matrix variable, whose columns are q, qd, qdd (and tau) of "
                 "every joint, in that order");
}

Dataset read_data_option(const std::string& path, const std::string& mat_variable, const JointTypes& joints,
                         bool require_tau, const std::string& joints_owner) {
  if (mat_variable.empty()) return read_dataset(path, joints, require_tau, joints_owner);
  return read_mat_dataset(path, mat_variable, joints, require_tau);
}

}  // namespace gipdyn::cli
