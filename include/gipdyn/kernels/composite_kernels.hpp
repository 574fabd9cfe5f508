#pragma once
// Product and sum of kernels, and the multiplicative polynomial kernel (MPK)
// built from them. These are the general (unfused) compositions; GipKernel is
// the fused equivalent of the GIP product, and the tests check one against the other.
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

class CompositeKernel : public Kernel {
 public:
  explicit CompositeKernel(std::vector<std::unique_ptr<Kernel>> children);
  CompositeKernel(const CompositeKernel& other);

  int num_params() const override;
  std::vector<std::string> param_names() const override;
  Eigen::VectorXd log_params() const override;
  void set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) override;

  void restrict_log_params(const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> lower,
                           Eigen::Ref<Eigen::VectorXd> upper) const override;

  int num_children() const { return static_cast<int>(children_.size()); }
  const Kernel& child(int i) const { return *children_[static_cast<size_t>(i)]; }

 protected:
  // Which child owns parameter p, and its index there.
  std::pair<int, int> locate(int p) const;
  int offset(int child) const;
  std::vector<std::unique_ptr<Kernel>> children_;
};

// k = prod_c k_c. The gradient w.r.t. a parameter of child c is the other
// children's product times that child's gradient.
class ProductKernel : public CompositeKernel {
 public:
  using CompositeKernel::CompositeKernel;
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<ProductKernel>(*this); }
  void cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const override;
  void diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const override;
  void gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p, Eigen::MatrixXd& dK) const override;
  void contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                KernelScratch& scratch) const override;
  void contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                      Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  // cross(Z, Z, K), with the further children's matrices in the scratch's
  // buffers: an NLL evaluation allocates no N x N matrix.
  void gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& scratch) const override;
  // One query through each child's own row(): the children's fast paths, one
  // N-vector allocated per further child.
  void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
           KernelScratch& scratch) const override;
  double self(const double* z, int feature_dim, KernelScratch& scratch) const override;
};

// k = structured(x, x') * envelope(x, x') with an RBF envelope of long
// lengthscales (docs/method.md section 13): near the data the structured
// kernel's functions, modulated slowly; far from every training input the
// prediction reverts to the prior mean instead of following a polynomial.
// Maximum likelihood can lengthen the envelope until it is the structured
// kernel alone when the data are that structured.
class EnvelopeKernel final : public ProductKernel {
 public:
  // Lengthscales at the start, in standard deviations of each input column.
  static constexpr double kStartLengthscales = 3.0;
  EnvelopeKernel(std::unique_ptr<Kernel> structured, std::unique_ptr<Kernel> envelope_rbf);
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<EnvelopeKernel>(*this); }
  // The structured kernel starts as alone; the envelope at variance 1 and kStartLengthscales.
  void initialize(const Eigen::MatrixXd& Z, double target_variance) override;
};

// k = sum_c k_c.
class SumKernel final : public CompositeKernel {
 public:
  using CompositeKernel::CompositeKernel;
  // initialize() gives child c the share shares[c] of the target variance
  // (equal shares unless set).
  SumKernel(std::vector<std::unique_ptr<Kernel>> children, std::vector<double> shares);
  void initialize(const Eigen::MatrixXd& Z, double target_variance) override;
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<SumKernel>(*this); }
  void cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const override;
  void diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const override;
  void gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p, Eigen::MatrixXd& dK) const override;
  void contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                KernelScratch& scratch) const override;
  void contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                      Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  void gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& scratch) const override;
  void contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                    Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  bool fuses_nll_contraction() const override { return true; }
  // As ProductKernel::row, summing.
  void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
           KernelScratch& scratch) const override;
  double self(const double* z, int feature_dim, KernelScratch& scratch) const override;
  // One plan per child: a finite expansion among them (friction) costs O(features) a query.
  void plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const override;
  double mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const MeanPlan& plan,
                  Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const override;

 private:
  std::vector<double> shares_;
};

// MPK of degree p on the given columns: prod_{s=1..p} (s0_s + sum_d l_{s,d} z_d z'_d),
// factors named prefix + ".factor<s>".
std::unique_ptr<ProductKernel> make_mpk(const std::vector<int>& columns, int degree, const std::string& prefix,
                                        const std::vector<std::string>& weight_labels);

}  // namespace gipdyn
