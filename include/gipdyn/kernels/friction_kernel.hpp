#pragma once
// Smooth friction and a torque offset of one joint (docs/method.md section 12):
//
//   k(v, v') = s_o + s_v v v' + s_c c(v) c(v') + s_s r(v) r(v'),
//   c(v) = tanh(v / v_c),   r(v) = exp(-(v / v_r)^2) c(v),
//
// with v the joint's velocity qd_i. Its functions are exactly
//   offset + viscous v + Coulomb tanh(v / v_c) + Stribeck exp(-(v / v_r)^2) tanh(v / v_c),
// i.e. the Stribeck friction curve with the sign smoothed over v_c, each weight
// with a zero-mean Gaussian prior of variance s_*. v_c and v_r are learned with
// the rest. Parameters (log): s_offset, s_viscous, s_coulomb, s_stribeck,
// v_coulomb, v_stribeck, named "<prefix>.<name>".
#include <string>

#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

// The four features (1, v, c(v), r(v)) of one velocity v for the given log v_c
// and log v_r, and, where asked, their derivatives in log v_c and log v_r.
Eigen::Vector4d friction_features(double v, double log_vc, double log_vr, Eigen::Vector4d* d_log_vc = nullptr,
                                  Eigen::Vector4d* d_log_vr = nullptr);

// The smallest Stribeck velocity v_r a fit may learn from these velocities:
// the kStribeckRows-th smallest non-zero |v| (rows at v = 0 see no Stribeck
// term). A narrower bump would sit between fewer rows than that, and its weight,
// free to grow, would fit a row or two exactly and predict torques orders of
// magnitude off at a velocity closer to 0 (a 7R arm, 1000 rows: v_r 9e-5 rad/s,
// one test row 1e4 N m off). Tiny (e^-30) without such rows.
double stribeck_velocity_floor(const Eigen::Ref<const Eigen::VectorXd>& velocities);
constexpr int kStribeckRows = 10;

class FrictionKernel final : public Kernel {
 public:
  // column: the velocity's column in the feature matrix Z.
  explicit FrictionKernel(int column, std::string prefix = "friction");

  std::unique_ptr<Kernel> clone() const override { return std::make_unique<FrictionKernel>(*this); }
  int num_params() const override { return kNumParams; }
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
  // Rank 4: k(z, Z) alpha = (s .* f(z)) . (F^T alpha), F folded once.
  void plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const override;
  double mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const MeanPlan& plan,
                  Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const override;

  // Each of the four terms starts with a quarter of target_variance (its weight
  // divided by the mean square of its feature); v_c starts at 5 % and v_r at
  // 20 % of the velocity's root mean square, so the smoothed sign is nearly a
  // step at the speeds of the data and the Stribeck bump sits at low speed.
  void initialize(const Eigen::MatrixXd& Z, double target_variance) override;
  // Keeps log v_r at or above log stribeck_velocity_floor of the rows' velocities.
  void restrict_log_params(const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> lower,
                           Eigen::Ref<Eigen::VectorXd> upper) const override;

  // The four features (1, v, c(v), r(v)) of one velocity.
  Eigen::Vector4d features(double v) const;

  static constexpr int kNumParams = 6;
  enum Param { kOffset = 0, kViscous, kCoulomb, kStribeck, kCoulombVelocity, kStribeckVelocity };

 private:
  // Features (N x 4) and, when wanted, their derivatives in log v_c and log v_r
  // (N x 4 each; only the c and r columns are non-zero).
  void feature_matrix(const Eigen::MatrixXd& Z, Eigen::MatrixXd& F, Eigen::MatrixXd* dF_vc = nullptr,
                      Eigen::MatrixXd* dF_vr = nullptr) const;
  // The four terms' variances, exp of the first four log-parameters.
  Eigen::Vector4d term_variances() const { return log_params_.head<4>().array().exp(); }

  int column_;
  std::string prefix_;
  Eigen::VectorXd log_params_;
};

}  // namespace gipdyn
