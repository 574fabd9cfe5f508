#include "gipdyn/io/mat_dataset.hpp"

#include <matio.h>

#include <memory>

#include "gipdyn/error.hpp"

namespace gipdyn {

Dataset read_mat_dataset(const std::string& path, const std::string& variable, const JointTypes& joints,
                         bool require_tau) {
  const int n = joints.size();
  const std::string what = "'" + path + "'";
  std::unique_ptr<mat_t, decltype(&Mat_Close)> mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY), &Mat_Close);
  if (!mat) throw Error("cannot open " + what + " as a MATLAB .mat file (missing, unreadable or not a .mat file)");
  std::unique_ptr<matvar_t, decltype(&Mat_VarFree)> var(Mat_VarRead(mat.get(), variable.c_str()), &Mat_VarFree);
  if (!var) {
    std::vector<std::string> held;
    Mat_Rewind(mat.get());
    while (matvar_t* info = Mat_VarReadNextInfo(mat.get())) {
      held.push_back(info->name ? info->name : "?");
      Mat_VarFree(info);
    }
    const std::string names = joined(held);
    throw Error(what + " has no variable '" + variable + "'; it holds: " + (names.empty() ? "nothing" : names) +
                " (name the variable to read)");
  }
  if (var->rank != 2 || var->isComplex || var->data == nullptr ||
      (var->class_type != MAT_C_DOUBLE && var->class_type != MAT_C_SINGLE))
    throw Error(what + ": variable '" + variable + "' is not a real 2-D double or single matrix");
  const auto rows = static_cast<Eigen::Index>(var->dims[0]), cols = static_cast<Eigen::Index>(var->dims[1]);
  const Eigen::Index needed = require_tau ? 4 * n : 3 * n;
  if (cols < needed)
    throw Error(what + ": variable '" + variable + "' has " + std::to_string(cols) + " columns but joints " +
                joints.str() + " need " + std::to_string(needed) + " (q, qd, qdd" + (require_tau ? ", tau" : "") +
                " per joint, in that order)");
  // Columns are positional, so a matrix of another arm would be read shifted: q of one joint as qd of
  // another. Extra columns are allowed, but not exactly those of another number of joints.
  const bool own_width = cols == 4 * n || (!require_tau && cols == 3 * n);
  if (!own_width && cols % 4 == 0)
    throw Error(what + ": variable '" + variable + "' has " + std::to_string(cols) + " columns, those of " +
                std::to_string(cols / 4) + " joints (q, qd, qdd, tau), but joints " + joints.str() + " are " +
                std::to_string(n) + "; give the joint types of the arm that logged it");
  if (rows < 1) throw Error(what + ": variable '" + variable + "' has no rows");
  Eigen::MatrixXd A(rows, cols);
  if (var->class_type == MAT_C_DOUBLE)
    A = Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(var->data), rows, cols);
  else
    A = Eigen::Map<const Eigen::MatrixXf>(static_cast<const float*>(var->data), rows, cols).cast<double>();
  if (!A.leftCols(needed).allFinite())
    throw Error(what + ": variable '" + variable + "' contains NaN or Inf; remove or repair those rows");
  Dataset d;
  d.X = A.leftCols(3 * n);
  if (require_tau) d.tau = A.middleCols(3 * n, n);
  return d;
}

Dataset read_robot_log(const std::string& path, const std::string& mat_variable, const JointTypes& joints,
                       bool require_tau, const std::string& joints_owner, const LogColumns& columns) {
  if (mat_variable.empty()) return read_dataset(path, joints, require_tau, joints_owner, columns);
  if (!columns.is_default())
    throw Error("'" + path + "': a .mat variable's columns are positional (q, qd, qdd, tau of every joint) and have "
                "no names for LogColumns to rename; leave LogColumns at gipdyn's names");
  return read_mat_dataset(path, mat_variable, joints, require_tau);
}

}  // namespace gipdyn
