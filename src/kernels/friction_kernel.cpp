#include "gipdyn/kernels/friction_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gipdyn/error.hpp"

namespace gipdyn {

FrictionKernel::FrictionKernel(int column, std::string prefix) : column_(column), prefix_(std::move(prefix)) {
  if (column < 0) throw Error("FrictionKernel: the velocity column must be >= 0");
  log_params_ = Eigen::VectorXd::Zero(kNumParams);
}

std::vector<std::string> FrictionKernel::param_names() const {
  return {prefix_ + ".s_offset",  prefix_ + ".s_viscous",  prefix_ + ".s_coulomb",
          prefix_ + ".s_stribeck", prefix_ + ".v_coulomb", prefix_ + ".v_stribeck"};
}

void FrictionKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) {
  if (p.size() != kNumParams) throw Error("FrictionKernel: wrong number of parameters");
  log_params_ = p;
}

namespace {

// friction_features from the inverse velocities 1 / v_c and 1 / v_r, which a
// loop over rows computes once.
Eigen::Vector4d features_from_inverse(double v, double inv_vc, double inv_vr, Eigen::Vector4d* d_log_vc,
                                      Eigen::Vector4d* d_log_vr) {
  const double a = v * inv_vc, u = v * inv_vr;
  const double c = std::tanh(a), e = std::exp(-u * u);
  // d tanh(v / v_c) / d log v_c = -(v / v_c) sech^2; d exp(-(v / v_r)^2) / d log v_r = 2 u^2 e.
  if (d_log_vc) {
    const double dc = -a * (1.0 - c * c);
    *d_log_vc << 0.0, 0.0, dc, e * dc;
  }
  if (d_log_vr) *d_log_vr << 0.0, 0.0, 0.0, 2.0 * u * u * e * c;
  return {1.0, v, c, e * c};
}

}  // namespace

Eigen::Vector4d friction_features(double v, double log_vc, double log_vr, Eigen::Vector4d* d_log_vc,
                                  Eigen::Vector4d* d_log_vr) {
  return features_from_inverse(v, std::exp(-log_vc), std::exp(-log_vr), d_log_vc, d_log_vr);
}

Eigen::Vector4d FrictionKernel::features(double v) const {
  return friction_features(v, log_params_(kCoulombVelocity), log_params_(kStribeckVelocity));
}

void FrictionKernel::feature_matrix(const Eigen::MatrixXd& Z, Eigen::MatrixXd& F, Eigen::MatrixXd* dF_vc,
                                    Eigen::MatrixXd* dF_vr) const {
  const Eigen::Index N = Z.rows();
  F.resize(N, 4);
  if (dF_vc) dF_vc->resize(N, 4);
  if (dF_vr) dF_vr->resize(N, 4);
  Eigen::Vector4d d_vc, d_vr;
  const double inv_vc = std::exp(-log_params_(kCoulombVelocity)), inv_vr = std::exp(-log_params_(kStribeckVelocity));
  for (Eigen::Index i = 0; i < N; ++i) {
    F.row(i) = features_from_inverse(Z(i, column_), inv_vc, inv_vr, dF_vc ? &d_vc : nullptr, dF_vr ? &d_vr : nullptr)
                   .transpose();
    if (dF_vc) dF_vc->row(i) = d_vc.transpose();
    if (dF_vr) dF_vr->row(i) = d_vr.transpose();
  }
}

double stribeck_velocity_floor(const Eigen::Ref<const Eigen::VectorXd>& velocities) {
  std::vector<double> speeds;
  speeds.reserve(static_cast<size_t>(velocities.size()));
  for (Eigen::Index i = 0; i < velocities.size(); ++i)
    if (velocities(i) != 0.0 && std::isfinite(velocities(i))) speeds.push_back(std::abs(velocities(i)));
  if (speeds.empty()) return std::exp(-30.0);
  const size_t k = std::min<size_t>(kStribeckRows, speeds.size()) - 1;
  std::nth_element(speeds.begin(), speeds.begin() + static_cast<std::ptrdiff_t>(k), speeds.end());
  return std::max(speeds[k], std::exp(-30.0));
}

void FrictionKernel::restrict_log_params(const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> lower,
                                         Eigen::Ref<Eigen::VectorXd> upper) const {
  lower(kStribeckVelocity) = std::max(lower(kStribeckVelocity), std::log(stribeck_velocity_floor(Z.col(column_))));
  upper(kStribeckVelocity) = std::max(upper(kStribeckVelocity), lower(kStribeckVelocity));
}

void FrictionKernel::initialize(const Eigen::MatrixXd& Z, double target_variance) {
  const double rms = std::sqrt(Z.col(column_).squaredNorm() / std::max<double>(1.0, static_cast<double>(Z.rows())));
  const double scale = rms > 1e-12 ? rms : 1.0;
  log_params_(kCoulombVelocity) = std::log(0.05 * scale);
  log_params_(kStribeckVelocity) = std::log(0.2 * scale);
  Eigen::MatrixXd F;
  feature_matrix(Z, F);
  const double share = std::max(target_variance, 1e-12) / 4.0;
  for (int k = 0; k < 4; ++k) {
    const double ms = F.col(k).squaredNorm() / std::max<double>(1.0, static_cast<double>(F.rows()));
    log_params_(k) = std::log(share / std::max(ms, 1e-12));
  }
}

void FrictionKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  Eigen::MatrixXd F1, F2;
  feature_matrix(Z1, F1);
  feature_matrix(Z2, F2);
  const Eigen::Vector4d s = term_variances();
  K.noalias() = F1 * s.asDiagonal() * F2.transpose();
}

void FrictionKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  Eigen::MatrixXd F;
  feature_matrix(Z, F);
  const Eigen::Vector4d s = term_variances();
  d = F.array().square().matrix() * s;
}

double FrictionKernel::self(const double* z, int /*feature_dim*/, KernelScratch& /*scratch*/) const {
  const Eigen::Vector4d f = features(z[column_]);
  return f.array().square().matrix().dot(term_variances());
}

void FrictionKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                         KernelScratch& /*scratch*/) const {
  const Eigen::Vector4d w = features(z[column_]).cwiseProduct(term_variances());
  const double inv_vc = std::exp(-log_params_(kCoulombVelocity)), inv_vr = std::exp(-log_params_(kStribeckVelocity));
  for (Eigen::Index i = 0; i < Z.rows(); ++i) out(i) = w.dot(features_from_inverse(Z(i, column_), inv_vc, inv_vr, nullptr, nullptr));
}

void FrictionKernel::plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const {
  Eigen::MatrixXd F;
  feature_matrix(Z, F);
  plan = MeanPlan{};
  // Element by element: assigned as one expression into the dynamic vector, GCC 12 warns falsely of an 8-wide
  // load from the 4-vector on -march=native builds (the packet loop it warns about never runs for 4 elements).
  const Eigen::VectorXd projected = F.transpose() * alpha;
  const Eigen::Vector4d variances = term_variances();
  plan.weights.resize(4);
  for (int k = 0; k < 4; ++k) plan.weights(k) = projected(k) * variances(k);
}

double FrictionKernel::mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha,
                                const MeanPlan& plan, Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const {
  if (plan.weights.size() != 4) return Kernel::mean_one(z, Z, alpha, plan, krow, scratch);
  return features(z[column_]).dot(plan.weights);
}

void FrictionKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                     Eigen::MatrixXd& dK) const {
  if (p < 0 || p >= kNumParams) throw Error("FrictionKernel: parameter index out of range");
  const Eigen::Vector4d s = term_variances();
  Eigen::MatrixXd F1, F2, D1, D2;
  if (p < 4) {
    feature_matrix(Z1, F1);
    feature_matrix(Z2, F2);
    dK.noalias() = s(p) * F1.col(p) * F2.col(p).transpose();
    return;
  }
  const bool vc = p == kCoulombVelocity;
  feature_matrix(Z1, F1, vc ? &D1 : nullptr, vc ? nullptr : &D1);
  feature_matrix(Z2, F2, vc ? &D2 : nullptr, vc ? nullptr : &D2);
  dK.noalias() = D1 * s.asDiagonal() * F2.transpose();
  dK.noalias() += F1 * s.asDiagonal() * D2.transpose();
}

void FrictionKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                              KernelScratch& scratch) const {
  // K = F S F^T is rank 4: every contraction is a 4 x 4 product with W F, never an N x N matrix.
  Eigen::MatrixXd &F = scratch.features, &WF = scratch.weighted_features;
  Eigen::MatrixXd Dc, Dr;
  feature_matrix(Z, F, &Dc, &Dr);
  WF.noalias() = W * F;
  const Eigen::Vector4d s = term_variances();
  for (int k = 0; k < 4; ++k) grad(k) += s(k) * F.col(k).dot(WF.col(k));
  // sum_ij W_ij (D_i S F_j + F_i S D_j) = 2 sum_k s_k D_k^T W F_k for a symmetric W.
  for (int k = 2; k < 4; ++k) {
    grad(kCoulombVelocity) += 2.0 * s(k) * Dc.col(k).dot(WF.col(k));
    grad(kStribeckVelocity) += 2.0 * s(k) * Dr.col(k).dot(WF.col(k));
  }
}

void FrictionKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                                    Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  // K = F1 S F2^T: sum_ij W_ij dK_ij = sum_k s_k (D1_k^T W F2_k + F1_k^T W D2_k) for the velocity scales.
  Eigen::MatrixXd &WF2 = scratch.features, &WtF1 = scratch.weighted_features;
  Eigen::MatrixXd F1, F2, Dc1, Dr1, Dc2, Dr2;
  feature_matrix(Z1, F1, &Dc1, &Dr1);
  feature_matrix(Z2, F2, &Dc2, &Dr2);
  WF2.noalias() = W * F2;
  WtF1.noalias() = W.transpose() * F1;
  const Eigen::Vector4d s = term_variances();
  for (int k = 0; k < 4; ++k) grad(k) += s(k) * F1.col(k).dot(WF2.col(k));
  for (int k = 2; k < 4; ++k) {
    grad(kCoulombVelocity) += s(k) * (Dc1.col(k).dot(WF2.col(k)) + Dc2.col(k).dot(WtF1.col(k)));
    grad(kStribeckVelocity) += s(k) * (Dr1.col(k).dot(WF2.col(k)) + Dr2.col(k).dot(WtF1.col(k)));
  }
}

}  // namespace gipdyn
