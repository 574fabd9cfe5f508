#include "gipdyn/kernels/parametric_kernel.hpp"

#include <cmath>
#include <cstring>

#include "gipdyn/error.hpp"
#include "gipdyn/robot/dynamics.hpp"

namespace gipdyn {

std::vector<std::string> dynamic_parameter_names(int num_joints, bool with_friction) {
  static const char* inertial[10] = {"m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"};
  std::vector<std::string> names;
  for (int l = 0; l < num_joints; ++l)
    for (const char* p : inertial) names.push_back("link" + std::to_string(l + 1) + "." + p);
  if (with_friction) {
    for (int j = 0; j < num_joints; ++j) names.push_back("joint" + std::to_string(j + 1) + ".viscous");
    for (int j = 0; j < num_joints; ++j) names.push_back("joint" + std::to_string(j + 1) + ".coulomb");
  }
  return names;
}

ParametricKernel::ParametricKernel(std::shared_ptr<const RobotModel> robot, int joint, bool with_friction)
    : robot_(std::move(robot)), joint_(joint), with_friction_(with_friction) {
  if (!robot_) throw Error("the parametric kernel needs the nominal robot (RobotPrior::robot)");
  if (joint < 0 || joint >= robot_->num_joints()) throw Error("parametric kernel: joint index out of range");
  const int p = (with_friction ? 12 : 10) * robot_->num_joints();
  log_params_ = Eigen::VectorXd::Zero(p);
  variances_ = Eigen::VectorXd::Ones(p);
}

std::vector<std::string> ParametricKernel::param_names() const {
  std::vector<std::string> names = dynamic_parameter_names(robot_->num_joints(), with_friction_);
  for (auto& n : names) n = "pp." + n + ".variance";
  return names;
}

void ParametricKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) {
  if (p.size() != log_params_.size()) throw Error("parametric kernel: wrong number of parameters");
  log_params_ = p;
  variances_ = p.array().exp().matrix();
}

Eigen::MatrixXd ParametricKernel::features(const Eigen::MatrixXd& Z) const {
  const int n = robot_->num_joints();
  if (Z.cols() < 3 * n) throw Error("parametric kernel: inputs have fewer than 3n columns");
  Eigen::MatrixXd Phi(Z.rows(), log_params_.size());
  RegressorWorkspace workspace(*robot_);
  Eigen::MatrixXd every_joint(n, log_params_.size());
  Eigen::VectorXd x(3 * n);
  for (Eigen::Index r = 0; r < Z.rows(); ++r) {
    x = Z.row(r).head(3 * n).transpose();
    regressor_into(*robot_, x.data(), x.data() + n, x.data() + 2 * n, with_friction_, workspace, every_joint);
    Phi.row(r) = every_joint.row(joint_);
  }
  return Phi;
}

void ParametricKernel::plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const {
  plan = MeanPlan{};
  plan.weights = variances_.cwiseProduct(features(Z).transpose() * alpha);
}

double ParametricKernel::mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha,
                                  const MeanPlan& plan, Eigen::Ref<Eigen::VectorXd> krow,
                                  KernelScratch& scratch) const {
  if (plan.weights.size() != log_params_.size()) return Kernel::mean_one(z, Z, alpha, plan, krow, scratch);
  return query_regressor(z, scratch).row(joint_).dot(plan.weights);
}

const Eigen::MatrixXd& ParametricKernel::query_regressor(const double* z, KernelScratch& scratch) const {
  const int n = robot_->num_joints();
  if (!scratch.regressor || scratch.regressor_robot != robot_.get()) {
    scratch.regressor = std::make_shared<RegressorWorkspace>(*robot_);
    scratch.regressor_robot = robot_.get();
    scratch.regressor_query.resize(0);
    scratch.training_regressor_of.resize(0, 0);
  }
  // Byte equality, so a query that differs from the last one in anything (even
  // the sign of a zero) gets its own regressor.
  const size_t query_bytes = 3 * static_cast<size_t>(n) * sizeof(double);
  const bool same_query = scratch.regressor_query.size() == 3 * n && scratch.regressor_rows.cols() == log_params_.size() &&
                          std::memcmp(scratch.regressor_query.data(), z, query_bytes) == 0;
  if (!same_query) {
    scratch.regressor_rows.resize(n, log_params_.size());
    regressor_into(*robot_, z, z + n, z + 2 * n, with_friction_, *scratch.regressor, scratch.regressor_rows);
    scratch.regressor_query.resize(3 * n);
    std::memcpy(scratch.regressor_query.data(), z, query_bytes);
  }
  return scratch.regressor_rows;
}

void ParametricKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                           KernelScratch& scratch) const {
  const int n = robot_->num_joints();
  const Eigen::Index N = Z.rows(), P = log_params_.size();
  if (Z.cols() < 3 * n) throw Error("parametric kernel: inputs have fewer than 3n columns");
  const Eigen::MatrixXd& phi = query_regressor(z, scratch);  // first: a new robot clears the cache below
  // Compared by content, not by address: a scratch may outlive the Z it was given.
  // (P tells friction columns apart.)
  const Eigen::MatrixXd& cached = scratch.training_regressor_of;
  const bool same_rows = cached.rows() == N && cached.cols() == 3 * n && scratch.training_regressor.cols() == P &&
                         cached == Z.leftCols(3 * n);
  if (!same_rows) {
    scratch.training_regressor_of = Z.leftCols(3 * n);
    scratch.training_regressor = stacked_regressor(*robot_, scratch.training_regressor_of, with_friction_);
  }
  scratch.regressor_weights = variances_.cwiseProduct(phi.row(joint_).transpose());
  // Joint joint_'s rows of the stacked regressor: every n-th row from joint_ on.
  const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>> rows(
      scratch.training_regressor.data() + joint_, N, P, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(N * n, n));
  out.noalias() = rows * scratch.regressor_weights;
}

double ParametricKernel::self(const double* z, int /*feature_dim*/, KernelScratch& scratch) const {
  return query_regressor(z, scratch).row(joint_).array().square().matrix().dot(variances_);
}

void ParametricKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  const Eigen::MatrixXd P1 = features(Z1);
  if (&Z1 == &Z2) {
    K.noalias() = P1 * variances_.asDiagonal() * P1.transpose();
  } else {
    K.noalias() = P1 * variances_.asDiagonal() * features(Z2).transpose();
  }
}

void ParametricKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  d = features(Z).array().square().matrix() * variances_;
}

void ParametricKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                       Eigen::MatrixXd& dK) const {
  if (p < 0 || p >= num_params()) throw Error("parametric kernel: parameter index out of range");
  dK.noalias() = variances_(p) * features(Z1).col(p) * features(Z2).col(p).transpose();
}

void ParametricKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                                KernelScratch& scratch) const {
  // sum_ij W_ij s_k phi_ik phi_jk = s_k phi_k^T W phi_k, for every k from one N x N x p product.
  scratch.features = features(Z);
  scratch.weighted_features.noalias() = W * scratch.features;
  grad += (variances_.array() * (scratch.features.array() * scratch.weighted_features.array()).colwise().sum().transpose()).matrix();
}

void ParametricKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                                      Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  // sum_ij W_ij s_k phi1_ik phi2_jk = s_k sum_i phi1_ik (W phi2)_ik.
  scratch.features = features(Z1);
  scratch.weighted_features.noalias() = W * features(Z2);
  grad += (variances_.array() * (scratch.features.array() * scratch.weighted_features.array()).colwise().sum().transpose()).matrix();
}

Eigen::VectorXd ParametricKernel::mean_square_features(const Eigen::MatrixXd& Z) const {
  return features(Z).array().square().colwise().mean().transpose();
}

void ParametricKernel::initialize(const Eigen::MatrixXd& Z, double target_variance) {
  const Eigen::VectorXd mean_sq = mean_square_features(Z);
  const double floor = 1e-12 * std::max(mean_sq.maxCoeff(), 1e-300);
  const int active = std::max(1, static_cast<int>((mean_sq.array() > floor).count()));
  for (Eigen::Index k = 0; k < mean_sq.size(); ++k)
    log_params_(k) = mean_sq(k) > floor ? std::log(target_variance / (active * mean_sq(k))) : 0.0;
  variances_ = log_params_.array().exp().matrix();
  target_variance_ = target_variance;
}

void ParametricKernel::restrict_log_params(const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> lower,
                                           Eigen::Ref<Eigen::VectorXd> upper) const {
  if (!(target_variance_ > 0.0) || Z.rows() == 0) return;
  const Eigen::VectorXd mean_sq = mean_square_features(Z);
  for (Eigen::Index k = 0; k < mean_sq.size(); ++k) {
    if (!(mean_sq(k) > 0.0)) continue;  // the joint's torque does not depend on it
    upper(k) = std::min(upper(k), std::log(kMaxParameterShare * target_variance_ / mean_sq(k)));
    lower(k) = std::min(lower(k), upper(k));
  }
}

}  // namespace gipdyn
