#include "gipdyn/kernels/rbf_kernel.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"

namespace gipdyn {

RbfKernel::RbfKernel(std::vector<int> columns, std::vector<std::string> labels, std::string prefix)
    : columns_(std::move(columns)), labels_(std::move(labels)), prefix_(std::move(prefix)) {
  if (labels_.size() != columns_.size()) throw Error("RbfKernel: one label per column is required");
  log_params_ = Eigen::VectorXd::Zero(1 + static_cast<Eigen::Index>(columns_.size()));
}

std::vector<std::string> RbfKernel::param_names() const {
  std::vector<std::string> names{prefix_ + ".variance"};
  for (const auto& l : labels_) names.push_back(prefix_ + ".lengthscale_" + l);
  return names;
}

void RbfKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) {
  if (p.size() != log_params_.size()) throw Error("RbfKernel: wrong number of parameters");
  log_params_ = p;
}

void RbfKernel::initialize(const Eigen::MatrixXd& Z, double target_variance) {
  log_params_(0) = std::log(std::max(target_variance, 1e-12));
  for (size_t d = 0; d < columns_.size(); ++d) {
    const auto c = Z.col(columns_[d]).array();
    const double var = Z.rows() > 1 ? (c - c.mean()).square().mean() : 0.0;
    log_params_(1 + static_cast<Eigen::Index>(d)) = var > 1e-12 ? 0.5 * std::log(var) : 0.0;
  }
}

Eigen::MatrixXd RbfKernel::scaled(const Eigen::MatrixXd& Z) const {
  Eigen::MatrixXd S(Z.rows(), static_cast<Eigen::Index>(columns_.size()));
  for (size_t d = 0; d < columns_.size(); ++d)
    S.col(static_cast<Eigen::Index>(d)) = Z.col(columns_[d]) * std::exp(-log_params_(1 + static_cast<Eigen::Index>(d)));
  return S;
}

bool RbfKernel::expansion_is_accurate(const Eigen::MatrixXd& S1, const Eigen::MatrixXd& S2) {
  if (S1.rows() == 0 || S2.rows() == 0) return true;
  // The expansion's rounding is about eps * max |s|^2 in the squared distance,
  // that is eps * max |s|^2 / 2 relative in k: keep it below about 1e-10. (No
  // centring to shrink |s|: a shift that depends on the rows would round a
  // block of a distributed matrix differently from the whole.)
  constexpr double kLargestSafeSquaredNorm = 1e6;
  return std::max(S1.rowwise().squaredNorm().maxCoeff(), S2.rowwise().squaredNorm().maxCoeff()) <=
         kLargestSafeSquaredNorm;
}

void RbfKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  const Eigen::MatrixXd S1 = scaled(Z1), S2 = scaled(Z2);
  K.resize(Z1.rows(), Z2.rows());
  if (expansion_is_accurate(S1, S2)) {
    K.noalias() = -2.0 * S1 * S2.transpose();
    K.colwise() += S1.rowwise().squaredNorm();
    K.rowwise() += S2.rowwise().squaredNorm().transpose();
  } else {
    K.setZero();
    for (Eigen::Index j = 0; j < K.cols(); ++j)
      for (Eigen::Index d = 0; d < S1.cols(); ++d) K.col(j).array() += (S1.col(d).array() - S2(j, d)).square();
  }
  K = (std::exp(log_params_(0)) * (-0.5 * K.array().max(0.0)).exp()).matrix();
}

void RbfKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  d = Eigen::VectorXd::Constant(Z.rows(), std::exp(log_params_(0)));
}

double RbfKernel::self(const double* /*z*/, int /*feature_dim*/, KernelScratch& /*scratch*/) const { return std::exp(log_params_(0)); }

void RbfKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                Eigen::MatrixXd& dK) const {
  cross(Z1, Z2, dK);
  if (p == 0) return;
  const Eigen::Index d = p - 1;
  const double inv = std::exp(-log_params_(p));
  const Eigen::VectorXd a = Z1.col(columns_[static_cast<size_t>(d)]) * inv;
  const Eigen::VectorXd b = Z2.col(columns_[static_cast<size_t>(d)]) * inv;
  for (Eigen::Index j = 0; j < dK.cols(); ++j) dK.col(j).array() *= (a.array() - b(j)).square();
}

void RbfKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                         KernelScratch& scratch) const {
  contract_gram(Z, W, nullptr, grad, scratch);
}

void RbfKernel::contract_with_gram(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, const Eigen::MatrixXd& K,
                                   Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  contract_gram(Z, W, &K, grad, scratch);
}

void RbfKernel::contract_gram(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, const Eigen::MatrixXd* K,
                              Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  // With M = W o K: sum_ij M_ij (s_id - s_jd)^2 = 2 sum_i s_id^2 (M 1)_i - 2 s_d^T M s_d,
  // or summed directly where that expansion would cancel (expansion_is_accurate).
  const Eigen::MatrixXd S = scaled(Z);
  if (!expansion_is_accurate(S, S)) {
    contract_cross_gram(Z, Z, W, K, grad, scratch);
    return;
  }
  Eigen::MatrixXd& M = scratch.a;
  if (K) {
    M = K->cwiseProduct(W);
  } else {
    cross(Z, Z, M);
    M.array() *= W.array();
  }
  grad(0) += M.sum();
  const Eigen::VectorXd r = M.rowwise().sum();
  Eigen::MatrixXd& MS = scratch.b;
  MS.noalias() = M * S;
  for (Eigen::Index d = 0; d < S.cols(); ++d)
    grad(1 + d) += 2.0 * S.col(d).cwiseAbs2().dot(r) - 2.0 * S.col(d).dot(MS.col(d));
}

void RbfKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                               Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  contract_cross_gram(Z1, Z2, W, nullptr, grad, scratch);
}

void RbfKernel::contract_cross_gram(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                                    const Eigen::MatrixXd* K, Eigen::Ref<Eigen::VectorXd> grad,
                                    KernelScratch& scratch) const {
  // With M = W o K: sum_ij M_ij (a_id - b_jd)^2 = a_d^2 . M 1 + b_d^2 . M^T 1 - 2 a_d^T M b_d,
  // or summed directly where that expansion would cancel (expansion_is_accurate).
  Eigen::MatrixXd& M = scratch.a;
  if (K) {
    M = K->cwiseProduct(W);
  } else {
    cross(Z1, Z2, M);
    M.array() *= W.array();
  }
  grad(0) += M.sum();
  const Eigen::MatrixXd A = scaled(Z1), B = scaled(Z2);
  if (!expansion_is_accurate(A, B)) {
    for (Eigen::Index j = 0; j < M.cols(); ++j)
      for (Eigen::Index d = 0; d < A.cols(); ++d)
        grad(1 + d) += (M.col(j).array() * (A.col(d).array() - B(j, d)).square()).sum();
    return;
  }
  const Eigen::VectorXd rows = M.rowwise().sum(), cols = M.colwise().sum().transpose();
  Eigen::MatrixXd& MB = scratch.b;
  MB.noalias() = M * B;
  for (Eigen::Index d = 0; d < A.cols(); ++d)
    grad(1 + d) += A.col(d).cwiseAbs2().dot(rows) + B.col(d).cwiseAbs2().dot(cols) - 2.0 * A.col(d).dot(MB.col(d));
}

void RbfKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                    KernelScratch& /*scratch*/) const {
  out.setZero();
  for (size_t d = 0; d < columns_.size(); ++d) {
    const double inv = std::exp(-log_params_(1 + static_cast<Eigen::Index>(d)));
    const int c = columns_[d];
    out.array() += ((Z.col(c).array() - z[c]) * inv).square();
  }
  out = (std::exp(log_params_(0)) * (-0.5 * out.array()).exp()).matrix();
}

}  // namespace gipdyn
