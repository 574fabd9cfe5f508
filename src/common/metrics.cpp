#include "gipdyn/metrics.hpp"

#include <limits>

#include "gipdyn/error.hpp"

namespace gipdyn {

Eigen::VectorXd column_variance(const Eigen::MatrixXd& target) {
  const Eigen::RowVectorXd mean = target.colwise().mean();
  Eigen::VectorXd var = (target.rowwise() - mean).array().square().colwise().mean().transpose();
  for (Eigen::Index j = 0; j < target.cols(); ++j)
    if (target.rows() > 0 && target.col(j).maxCoeff() == target.col(j).minCoeff()) var(j) = 0.0;
  return var;
}

Accuracy compute_accuracy(const Eigen::MatrixXd& target, const Eigen::MatrixXd& prediction) {
  if (target.rows() != prediction.rows() || target.cols() != prediction.cols() || target.rows() == 0)
    throw Error("accuracy: target and prediction must have the same, non-zero shape");
  Accuracy a;
  a.mse = (target - prediction).array().square().colwise().mean().transpose();
  const Eigen::VectorXd var = column_variance(target);
  a.nmse.resize(a.mse.size());
  for (Eigen::Index j = 0; j < a.mse.size(); ++j)
    a.nmse(j) = var(j) > 0.0 ? a.mse(j) / var(j) : std::numeric_limits<double>::infinity();
  a.gmse = a.mse.sum();
  return a;
}

}  // namespace gipdyn
