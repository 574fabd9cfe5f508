#include "gipdyn/training_data.hpp"

#include "gipdyn/error.hpp"

namespace gipdyn {

void validate_training_data(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints) {
  const int n = joints.size();
  if (X.cols() != 3 * n)
    throw Error("inputs have " + std::to_string(X.cols()) + " columns but joints " + joints.str() + " need " +
                std::to_string(3 * n) + " (q, qd, qdd per joint)");
  if (Y.cols() != n)
    throw Error("torques have " + std::to_string(Y.cols()) + " columns but joints " + joints.str() + " need " +
                std::to_string(n));
  if (X.rows() != Y.rows()) throw Error("inputs and torques have different numbers of rows");
  if (X.rows() < kMinTrainingRows)
    throw Error("only " + std::to_string(X.rows()) + " training rows; at least " + std::to_string(kMinTrainingRows) +
                " are needed");
  if (!X.allFinite() || !Y.allFinite()) throw Error("training data contain NaN or Inf; remove or repair those rows");
}

std::vector<Eigen::Index> constant_step_indices(Eigen::Index rows, Eigen::Index count) {
  std::vector<Eigen::Index> idx;
  if (count <= 0 || count >= rows) {
    for (Eigen::Index r = 0; r < rows; ++r) idx.push_back(r);
    return idx;
  }
  // floor(k rows / count): evenly spread over all rows even when rows / count is
  // not an integer (6340 rows -> 4000 must not keep just the first 4000).
  for (Eigen::Index k = 0; k < count; ++k) idx.push_back(k * rows / count);
  return idx;
}

}  // namespace gipdyn
