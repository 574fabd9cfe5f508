#pragma once
// The Geometrically Inspired Polynomial kernel (docs/method.md section 2):
//
//   k(x, x') = prod_{b} MPK_2(z_b, z_b') * MPK_1(a, a')
//              [ + l_v qd_i qd_i' + l_c sign(qd_i) sign(qd_i')   for gip-friction ]
//
// z_b = (cos q_b, sin q_b) for a revolute joint, (q_b) for a prismatic one;
// a = (qdd_1..qdd_n, qd_j qd_k for j <= k). Every factor is a linear kernel with a bias.
//
// This class is the fused implementation used for training and prediction.
// to_composite() returns the same kernel built from LinearKernel/ProductKernel/SumKernel
// with the same parameters in the same order (tests compare the two).
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/features.hpp"
#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

class GipKernel final : public Kernel {
 public:
  // friction_joint < 0: plain GIP. Otherwise adds the viscous and Coulomb friction
  // term of that joint (0-based), i.e. the gip-friction kernel of joint friction_joint.
  explicit GipKernel(const FeatureMap& features, int friction_joint = -1);

  std::unique_ptr<Kernel> clone() const override { return std::make_unique<GipKernel>(*this); }
  int num_params() const override { return static_cast<int>(log_params_.size()); }
  std::vector<std::string> param_names() const override;
  Eigen::VectorXd log_params() const override { return log_params_; }
  void set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) override;

  void cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const override;
  void diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const override;
  void gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p, Eigen::MatrixXd& dK) const override;
  void contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                KernelScratch& scratch) const override;
  void gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& scratch) const override;
  void contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                      Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  void contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                    Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const override;
  bool fuses_nll_contraction() const override { return true; }
  void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
           KernelScratch& scratch) const override;
  double self(const double* z, int feature_dim, KernelScratch& scratch) const override;

  // Data-driven start (docs/method.md section 5): every factor's diagonal is about
  // target_variance^(1/#factors); each weight is divided by the mean square of its
  // feature; the two factors of an MPK_2 start apart (bias/weight shares 0.25/0.75 and 0.75/0.25).
  void initialize(const Eigen::MatrixXd& Z, double target_variance) override;

  std::unique_ptr<Kernel> to_composite() const;

  // out(j) = k_j(z, Z) . alpha_j for several GIP kernels on the same training
  // features (the joints of one model): one pass over Z in row blocks, the
  // acceleration factors of all joints in one small GEMM per block. No
  // allocation once the scratch has its size.
  static void dot_rows(const std::vector<const GipKernel*>& kernels, const std::vector<const Eigen::VectorXd*>& alphas,
                       const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                       KernelScratch& scratch);
  bool has_friction() const { return friction_joint_ >= 0; }

  // Where queries share their positions: k(z, z_i) is the position factors' product P_i(z) times the
  // acceleration factor, which is affine in the query's acceleration features a (qdd and the qd products),
  // plus the friction term, linear in the query's friction features. So kernel j's mean at every query with
  // z's positions is affine_value(coeff.col(j), query) with coeff (affine_size() x J) from one pass over Z:
  // coeff = (s0 sum_i u_i, w_d sum_i u_i a_id for each d, the friction weights times sum_i alpha_i of the
  // friction features), u_i = alpha_i P_i(z). No allocation once the scratch has its size.
  static void affine_coefficients(const std::vector<const GipKernel*>& kernels,
                                  const std::vector<const Eigen::VectorXd*>& alphas, const double* z,
                                  const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::MatrixXd> coeff, KernelScratch& scratch);
  int affine_size() const { return static_cast<int>(acceleration_.columns.size()) + 3; }
  // The mean at query z from this kernel's coefficients (affine_coefficients' column).
  double affine_value(const Eigen::Ref<const Eigen::VectorXd>& coeff, const double* z) const;

 private:
  // k(z, z), which needs no scratch.
  double value_at_itself(const double* z) const;
  struct Factor {
    std::vector<int> columns;  // 1 or 2 position columns, or the acceleration group
    int offset;                // index of its log s0; weights follow
  };
  template <class WeightColumn>
  // Z1 == Z2 with `symmetric`: K(Z, Z) over its lower triangle; else K(Z1, Z2).
  void fused_contract(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, bool symmetric,
                      WeightColumn&& weight_column, Eigen::Ref<Eigen::VectorXd> grad,
                      KernelScratch& scratch) const;
  void acceleration_factor_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& A) const;
  // col (rows i0 .. i0+m of Z) *= the position factors, then += the friction
  // term, for the query whose feature c is zq(c). No allocation.
  template <class Query, class Column>
  void apply_position_and_friction(const Query& zq, const Eigen::MatrixXd& Z, Eigen::Index i0, Eigen::Index m,
                                   Column col) const;
  // col *= the position factors alone.
  template <class Query, class Column>
  void apply_position(const Query& zq, const Eigen::MatrixXd& Z, Eigen::Index i0, Eigen::Index m, Column col) const;

  FeatureMap features_;
  std::vector<Factor> position_factors_;  // two per joint, in joint order
  Factor acceleration_;
  int acc_first_column_ = 0;  // the acceleration group is contiguous in Z
  int friction_joint_ = -1;
  int friction_offset_ = -1;
  Eigen::VectorXd log_params_;
  Eigen::VectorXd weights_;  // exp(log_params_), refreshed wherever log_params_ changes
};

}  // namespace gipdyn
