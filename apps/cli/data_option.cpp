#include "data_option.hpp"

namespace gipdyn::cli {

void add_data_option(CLI::App& app, std::string& path, std::string& mat_variable, const std::string& csv_help) {
  app.add_option("--data", path, csv_help + ", or a .mat file with --mat-variable")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--mat-variable", mat_variable,
                 "--data is a MATLAB .mat file: read this matrix variable, whose columns are q, qd, qdd (and tau) of "
                 "every joint, in that order");
}

}  // namespace gipdyn::cli
