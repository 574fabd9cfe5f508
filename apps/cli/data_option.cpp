#include "data_option.hpp"

#include <optional>

#include "field_names.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn::cli {

void add_columns_option(CLI::App& app, std::string& columns) {
  app.add_option("--columns", columns,
                 "What the log calls gipdyn's columns, when it has other names: q=PATTERN,qd=PATTERN,qdd=PATTERN,"
                 "tau=PATTERN, {i} the joint's number from 1 and {i0} from 0 (e.g. q=position_{i0},qd=velocity_{i0},"
                 "tau=effort_{i0} for a ROS joint_states export), or a JSON file of them; quantities not named keep "
                 "gipdyn's names (docs/reference/log-format.md)");
}

void add_data_option(CLI::App& app, std::string& path, std::string& mat_variable, std::string& columns,
                     const std::string& csv_help) {
  app.add_option("--data", path, csv_help + ", or a .mat file with --mat-variable")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--mat-variable", mat_variable,
                 "--data is a MATLAB .mat file: read this matrix variable, whose columns are q, qd, qdd (and tau) of "
                 "every joint, in that order");
  add_columns_option(app, columns);
}

JointTypes joint_types_option(const std::string& joints, const std::string& path, const std::string& mat_variable,
                              const std::string& robot, const LogColumns& columns) {
  if (!joints.empty()) {
    const JointTypes given = JointTypes::parse(joints);
    if (mat_variable.empty()) {
      std::optional<JointTypes> recorded;
      try {
        recorded = sidecar_joint_types(path);
      } catch (const Error&) {  // --joints says what the unreadable sidecar would have
      }
      if (recorded && recorded->str() != given.str())
        print_warnings({"--joints " + given.str() + " differs from the joint types " + recorded->str() + " that '" +
                        path + ".json' records for this log; using --joints"});
    }
    return given;
  }
  std::string found;
  int n = 0;  // joints the CSV's columns name; 0 for a .mat file, whose columns name none
  if (mat_variable.empty()) {
    n = joint_column_count(read_csv_header(path, columns));
    if (const std::optional<JointTypes> recorded = sidecar_joint_types(path)) {
      if (static_cast<int>(recorded->size()) != n)
        throw Error("'" + path + ".json' records " + std::to_string(recorded->size()) + " joint types (" +
                    recorded->str() + ") but '" + path + "' has " + std::to_string(n) +
                    " joint(s): give --joints, or the sidecar that belongs to this log");
      return *recorded;
    }
    if (n > 0)
      found = "; '" + path + "' has " + std::to_string(n) + " joint(s) (q1..q" + std::to_string(n) + "), e.g. --joints " +
              std::string(static_cast<size_t>(n), 'R') + " if every joint is revolute";
  }
  if (!robot.empty()) {
    const JointTypes of_robot = load_robot(robot).joint_types();
    if (n > 0 && static_cast<int>(of_robot.size()) != n)
      throw Error("--robot " + robot + " has " + std::to_string(of_robot.size()) + " joints (" + of_robot.str() +
                  ") but '" + path + "' has " + std::to_string(n) + " (q1..q" + std::to_string(n) +
                  "): give the robot that made this log, or --joints");
    return of_robot;
  }
  throw Error("--joints is required: the joint types, one letter per joint, R (revolute) or P (prismatic), which a "
              "log cannot tell apart (a log written by gipdyn simulate records them in its .json sidecar)" + found);
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
