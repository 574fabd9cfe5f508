#pragma once
// Accuracy metrics of docs/method.md section 7.
#include <Eigen/Dense>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

struct Accuracy {
  Eigen::VectorXd mse;   // per joint: mean_t (tau - tau_hat)^2
  Eigen::VectorXd nmse;  // per joint: mse / population variance of tau
  double gmse = 0.0;     // sum of the per-joint MSEs
};

// Population variance of each column of target. A column whose values are all
// equal gets exactly 0: the rounding of its mean would otherwise leave a variance
// of about 1e-34 (37 rows of 0.1) and an nMSE of 1e26 where the nMSE is undefined.
Eigen::VectorXd column_variance(const Eigen::MatrixXd& target);

// target and prediction: N x n. A constant target column has an nMSE of inf.
Accuracy compute_accuracy(const Eigen::MatrixXd& target, const Eigen::MatrixXd& prediction);

}  // namespace gipdyn
