#pragma once
// Linear kernel with an optional bias on a set of feature columns:
//   k(z, z') = s0 + sum_d l_d z_d z'_d,   s0 > 0 (if present), l_d > 0.
// One factor of an MPK; without bias, the GIP-friction term.
#include <string>
#include <vector>

#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

class LinearKernel final : public Kernel {
 public:
  // weight_labels name each column's weight: parameter names are
  // prefix + ".s0" and prefix + ".l_" + label.
  LinearKernel(std::vector<int> columns, bool bias, std::string prefix, std::vector<std::string> weight_labels);

  std::unique_ptr<Kernel> clone() const override { return std::make_unique<LinearKernel>(*this); }
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
  void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
           KernelScratch& scratch) const override;
  double self(const double* z, int feature_dim, KernelScratch& scratch) const override;

  const std::vector<int>& columns() const { return columns_; }
  bool has_bias() const { return bias_; }

 private:
  double bias_value() const;
  double weight(int d) const;
  Eigen::MatrixXd weighted_slice(const Eigen::MatrixXd& Z) const;  // Z[:, cols] * diag(l)

  std::vector<int> columns_;
  bool bias_;
  std::string prefix_;
  std::vector<std::string> labels_;
  Eigen::VectorXd log_params_;  // [log s0 (if bias)], log l_1 .. log l_D
};

}  // namespace gipdyn
