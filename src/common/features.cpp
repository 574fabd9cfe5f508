#include "gipdyn/features.hpp"

#include <cmath>

namespace gipdyn {

FeatureMap::FeatureMap(const JointTypes& joints) : joints_(joints) {
  const int n = joints.size();
  for (int i = 0; i < n; ++i) names_.push_back("q" + std::to_string(i + 1));
  for (int i = 0; i < n; ++i) names_.push_back("qd" + std::to_string(i + 1));
  for (int i = 0; i < n; ++i) names_.push_back("qdd" + std::to_string(i + 1));
  for (int b = 0; b < n; ++b) {
    std::vector<int> group;
    const std::string j = std::to_string(b + 1);
    if (joints.is_revolute(b)) {
      group.push_back(feature_dim());
      names_.push_back("cos_q" + j);
      group.push_back(feature_dim());
      names_.push_back("sin_q" + j);
    } else {
      group.push_back(feature_dim());
      names_.push_back("q" + j);
    }
    position_groups_.push_back(group);
  }
  for (int i = 0; i < n; ++i) {
    acceleration_group_.push_back(feature_dim());
    names_.push_back("qdd" + std::to_string(i + 1));
  }
  for (int j = 0; j < n; ++j) {
    for (int k = j; k < n; ++k) {
      acceleration_group_.push_back(feature_dim());
      names_.push_back("qd" + std::to_string(j + 1) + "qd" + std::to_string(k + 1));
    }
  }
  friction_offset_ = feature_dim();
  for (int i = 0; i < n; ++i) names_.push_back("qd" + std::to_string(i + 1));
  for (int i = 0; i < n; ++i) names_.push_back("sign_qd" + std::to_string(i + 1));
}

void FeatureMap::compute_row(const double* x, double* z) const {
  const int n = num_joints();
  int c = 0;
  for (int k = 0; k < 3 * n; ++k) z[c++] = x[k];
  for (int b = 0; b < n; ++b) {
    if (joints_.is_revolute(b)) {
      z[c++] = std::cos(x[b]);
      z[c++] = std::sin(x[b]);
    } else {
      z[c++] = x[b];
    }
  }
  for (int i = 0; i < n; ++i) z[c++] = x[2 * n + i];
  for (int j = 0; j < n; ++j)
    for (int k = j; k < n; ++k) z[c++] = x[n + j] * x[n + k];
  for (int i = 0; i < n; ++i) z[c++] = x[n + i];
  for (int i = 0; i < n; ++i) {
    const double v = x[n + i];
    z[c++] = (v > 0.0) - (v < 0.0);
  }
}

Eigen::MatrixXd FeatureMap::compute(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  const Eigen::Index rows = X.rows();
  // Row-major scratch keeps compute_row the single definition of the map.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Xr = X;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> Zr(rows, feature_dim());
  for (Eigen::Index r = 0; r < rows; ++r) compute_row(Xr.row(r).data(), Zr.row(r).data());
  return Zr;
}

}  // namespace gipdyn
