#pragma once
// Accuracy metrics of docs/method.md section 7.
#include <Eigen/Dense>

namespace gipdyn {

struct Accuracy {
  Eigen::VectorXd mse;   // per joint: mean_t (tau - tau_hat)^2
  Eigen::VectorXd nmse;  // per joint: mse / population variance of tau
  double gmse = 0.0;     // sum of the per-joint MSEs
};

// target and prediction: N x n.
Accuracy compute_accuracy(const Eigen::MatrixXd& target, const Eigen::MatrixXd& prediction);

}  // namespace gipdyn
