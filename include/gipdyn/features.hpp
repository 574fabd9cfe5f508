#pragma once
// The feature map shared by every kernel of an n-joint robot.
//
// A raw input row is x = (q1..qn, qd1..qdn, qdd1..qddn). Every kernel reads
// columns of one feature matrix Z (one sample per row) laid out as
//   [ x (3n columns) | GIP position features | acceleration/velocity group | friction ]
// where the GIP position features are (cos q_b, sin q_b) for a revolute joint b and
// (q_b) for a prismatic one, the acceleration/velocity group is
// a = (qdd_1..qdd_n, qd_j qd_k for j <= k), and the friction block is
// (qd_1..qd_n, sign(qd_1)..sign(qd_n)). Kernels hold column indices into Z, so
// composite kernels (GIP + RBF, ...) share one Z.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

class FeatureMap {
 public:
  explicit FeatureMap(const JointTypes& joints);

  const JointTypes& joints() const { return joints_; }
  int num_joints() const { return joints_.size(); }
  int input_dim() const { return 3 * num_joints(); }
  int feature_dim() const { return static_cast<int>(names_.size()); }

  // Column indices.
  int q(int i) const { return i; }
  int qd(int i) const { return num_joints() + i; }
  int qdd(int i) const { return 2 * num_joints() + i; }
  // Position group of joint b: 2 columns (cos, sin) if revolute, 1 column if prismatic.
  const std::vector<int>& position_group(int b) const { return position_groups_[static_cast<size_t>(b)]; }
  // The acceleration/velocity group a.
  const std::vector<int>& acceleration_group() const { return acceleration_group_; }
  int friction_qd(int i) const { return friction_offset_ + i; }
  int friction_sign(int i) const { return friction_offset_ + num_joints() + i; }

  // Short column names used in hyperparameter names: "q1", "cos_q2", "qd1qd3", "sign_qd2".
  const std::string& name(int column) const { return names_[static_cast<size_t>(column)]; }

  // Z (rows x feature_dim) from X (rows x 3n).
  Eigen::MatrixXd compute(const Eigen::Ref<const Eigen::MatrixXd>& X) const;
  // One row into caller-owned storage (no allocation): x has 3n entries, z feature_dim.
  void compute_row(const double* x, double* z) const;

 private:
  JointTypes joints_;
  std::vector<std::vector<int>> position_groups_;
  std::vector<int> acceleration_group_;
  int friction_offset_ = 0;
  std::vector<std::string> names_;
};

}  // namespace gipdyn
