#include "data_option.hpp"

#include "field_names.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn::cli {

void add_data_option(CLI::App& app, std::string& path, std::string& mat_variable, const std::string& csv_help) {
  app.add_option("--data", path, csv_help + ", or a .mat file with --mat-variable")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--mat-variable", mat_variable,
                 "--data is a MATLAB .mat file: read this matrix variable, whose columns are q, qd, qdd (and tau) of "
                 "every joint, in that order");
}

JointTypes joint_types_option(const std::string& joints, const std::string& path, const std::string& mat_variable) {
  if (!joints.empty()) return JointTypes::parse(joints);
  std::string found;
  if (mat_variable.empty()) {
    const int n = joint_column_count(read_csv_header(path));
    if (n > 0)
      found = "; '" + path + "' has " + std::to_string(n) + " joint(s) (q1..q" + std::to_string(n) +
              "), e.g. --joints " + std::string(static_cast<size_t>(n), 'R');
  }
  throw Error("--joints is required: the joint types, one letter per joint, R (revolute) or P (prismatic), which a "
              "log cannot tell apart" + found);
}

void warn_about_extrapolation(const Estimator& estimator, const Eigen::MatrixXd& X, const std::string& path) {
  // A sparse model keeps only its inducing rows, whose box is narrower than the data's.
  const InverseDynamicsModel* gp = estimator.gp_model();
  if (gp == nullptr || gp->is_sparse() || gp->training_inputs().rows() == 0) return;
  const std::string warning =
      extrapolation_warning(InputBox::of(gp->training_inputs()), X, estimator.joints(), "'" + path + "'");
  if (!warning.empty()) print_warnings({warning});
}

}  // namespace gipdyn::cli
