#pragma once
// Squared-exponential kernel with ARD lengthscales (docs/method.md section 6):
//   k(z, z') = s2 exp(-1/2 sum_d (z_d - z'_d)^2 / ell_d^2)
// Parameters: log s2 ("rbf.variance"), log ell_d ("rbf.lengthscale_<column>").
#include <string>
#include <vector>

#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

class RbfKernel final : public Kernel {
 public:
  RbfKernel(std::vector<int> columns, std::vector<std::string> labels, std::string prefix = "rbf");

  std::unique_ptr<Kernel> clone() const override { return std::make_unique<RbfKernel>(*this); }
  int num_params() const override { return static_cast<int>(log_params_.size()); }
  std::vector<std::string> param_names() const override;
  Eigen::VectorXd log_params() const override { return log_params_; }
  void set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) override;

  void cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const override;
  void diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const override;
  void gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p, Eigen::MatrixXd& dK) const override;
  void contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                KernelScratch& scratch) const override;
  void contract_with_gram(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, const Eigen::MatrixXd& K,
                          Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  void contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                      Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
           KernelScratch& scratch) const override;
  double self(const double* z, int feature_dim, KernelScratch& scratch) const override;

  // variance = target_variance, lengthscale_d = standard deviation of column d.
  void initialize(const Eigen::MatrixXd& Z, double target_variance) override;

 private:
  Eigen::MatrixXd scaled(const Eigen::MatrixXd& Z) const;  // Z[:, cols] / ell
  // contract() and contract_cross() with K = k(Z1, Z2) given, or computed where null.
  void contract_gram(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, const Eigen::MatrixXd* K,
                     Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const;
  void contract_cross_gram(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                           const Eigen::MatrixXd* K, Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const;
  // Whether |a - b|^2 = |a|^2 + |b|^2 - 2 a.b (one matrix product) is accurate
  // for the scaled inputs S1, S2: it is not when a lengthscale is tiny against
  // the inputs (scaled values of 1e8 leave nothing of a distance of 1 after
  // cancellation), so callers then sum the squared differences directly.
  static bool expansion_is_accurate(const Eigen::MatrixXd& S1, const Eigen::MatrixXd& S2);

  std::vector<int> columns_;
  std::vector<std::string> labels_;
  std::string prefix_;
  Eigen::VectorXd log_params_;  // log s2, log ell_1..ell_D
};

}  // namespace gipdyn
