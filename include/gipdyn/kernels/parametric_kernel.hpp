#pragma once
// The parametric-prior (PP) kernel of docs/method.md section 6: the rigid-body regressor
// row of one joint, computed with the robot's nominal kinematics, with a
// Gaussian prior of diagonal covariance on the dynamic parameters:
//   k(x, x') = phi_i(x) diag(s) phi_i(x')^T.
// Parameters: log s_k, one per dynamic parameter (10 per link, plus viscous and
// Coulomb friction per joint when built with friction).
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/kernels/kernel.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

class ParametricKernel final : public Kernel {
 public:
  ParametricKernel(std::shared_ptr<const RobotModel> robot, int joint, bool with_friction);

  std::unique_ptr<Kernel> clone() const override { return std::make_unique<ParametricKernel>(*this); }
  int num_params() const override { return static_cast<int>(log_params_.size()); }
  std::vector<std::string> param_names() const override;
  Eigen::VectorXd log_params() const override { return log_params_; }
  void set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) override;

  void cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const override;
  void diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const override;
  void gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p, Eigen::MatrixXd& dK) const override;
  void contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                KernelScratch& scratch) const override;
  void contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                      Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;

  // s_k = target / (active parameters * mean phi_k^2) for every parameter the
  // joint's torque depends on, so that k(x, x) starts near target on average.
  void initialize(const Eigen::MatrixXd& Z, double target_variance) override;

  // Caps each s_k so that the parameter's prior share of k(x, x) on the rows Z,
  // s_k mean phi_k^2, stays below kMaxParameterShare times the target variance
  // of initialize(). The regressor's columns are linearly dependent (the base
  // parameters are fewer than the standard ones), and without a cap the
  // likelihood can send a few variances to 1e9 (link 2's mass on a UR10), where the
  // N x N kernel matrix of the final fit is no longer positive definite in
  // double precision.
  void restrict_log_params(const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> lower,
                           Eigen::Ref<Eigen::VectorXd> upper) const override;
  static constexpr double kMaxParameterShare = 100.0;

  // One query's mean in weight space: the plan holds diag(s) Phi(Z)^T alpha, so
  // a query costs one regressor instead of N; no allocation once the scratch
  // has its buffers.
  void plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const override;
  double mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const MeanPlan& plan,
                  Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const override;
  // k(z, Z) = Phi(Z) diag(s) phi(z) from the regressor of Z, computed once per
  // scratch and Z (a predictive variance's query: one regressor, not N).
  void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
           KernelScratch& scratch) const override;
  // phi(z) diag(s) phi(z)^T from the query's regressor the joints share (no allocation).
  double self(const double* z, int feature_dim, KernelScratch& scratch) const override;

  // Regressor rows of the kernel's joint for every row of Z (reads the first 3n columns).
  Eigen::MatrixXd features(const Eigen::MatrixXd& Z) const;
  bool weight_space_features(const Eigen::MatrixXd& Z, Eigen::MatrixXd& Phi) const override {
    Phi = features(Z);
    return true;
  }

 private:
  // The mean over the rows of Z of each regressor column's square: what initialize
  // scales the variances by and restrict_log_params caps them by.
  Eigen::VectorXd mean_square_features(const Eigen::MatrixXd& Z) const;

  std::shared_ptr<const RobotModel> robot_;
  int joint_;
  bool with_friction_;
  // Every joint's regressor rows of the query z (n x P), computed once for the
  // joints of one query that share the scratch.
  const Eigen::MatrixXd& query_regressor(const double* z, KernelScratch& scratch) const;

  Eigen::VectorXd log_params_, variances_;
  double target_variance_ = 0.0;  // of initialize(); 0 before it
};

// Names of the dynamic parameters in regressor order: "link2.mcx", "joint3.coulomb".
std::vector<std::string> dynamic_parameter_names(int num_joints, bool with_friction);

}  // namespace gipdyn
