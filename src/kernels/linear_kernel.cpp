#include "gipdyn/kernels/linear_kernel.hpp"

#include <cmath>

#include "gipdyn/error.hpp"

namespace gipdyn {

LinearKernel::LinearKernel(std::vector<int> columns, bool bias, std::string prefix,
                           std::vector<std::string> weight_labels)
    : columns_(std::move(columns)), bias_(bias), prefix_(std::move(prefix)), labels_(std::move(weight_labels)) {
  if (labels_.size() != columns_.size()) throw Error("LinearKernel: one weight label per column is required");
  log_params_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(columns_.size()) + (bias_ ? 1 : 0));
}

std::vector<std::string> LinearKernel::param_names() const {
  std::vector<std::string> names;
  if (bias_) names.push_back(prefix_ + ".s0");
  for (const auto& l : labels_) names.push_back(prefix_ + ".l_" + l);
  return names;
}

void LinearKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) {
  if (p.size() != log_params_.size()) throw Error("LinearKernel: wrong number of parameters");
  log_params_ = p;
}

double LinearKernel::bias_value() const { return bias_ ? std::exp(log_params_(0)) : 0.0; }
double LinearKernel::weight(int d) const { return std::exp(log_params_(d + (bias_ ? 1 : 0))); }

Eigen::MatrixXd LinearKernel::weighted_slice(const Eigen::MatrixXd& Z) const {
  Eigen::MatrixXd S(Z.rows(), static_cast<Eigen::Index>(columns_.size()));
  for (size_t d = 0; d < columns_.size(); ++d) S.col(static_cast<Eigen::Index>(d)) = weight(static_cast<int>(d)) * Z.col(columns_[d]);
  return S;
}

void LinearKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  Eigen::MatrixXd B(Z2.rows(), static_cast<Eigen::Index>(columns_.size()));
  for (size_t d = 0; d < columns_.size(); ++d) B.col(static_cast<Eigen::Index>(d)) = Z2.col(columns_[d]);
  K.resize(Z1.rows(), Z2.rows());
  K.noalias() = weighted_slice(Z1) * B.transpose();
  K.array() += bias_value();
}

void LinearKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  d = Eigen::VectorXd::Constant(Z.rows(), bias_value());
  for (size_t c = 0; c < columns_.size(); ++c) d.array() += weight(static_cast<int>(c)) * Z.col(columns_[c]).array().square();
}

void LinearKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                   Eigen::MatrixXd& dK) const {
  if (bias_ && p == 0) {
    dK = Eigen::MatrixXd::Constant(Z1.rows(), Z2.rows(), bias_value());
    return;
  }
  const int d = p - (bias_ ? 1 : 0);
  dK.noalias() = weight(d) * Z1.col(columns_[static_cast<size_t>(d)]) * Z2.col(columns_[static_cast<size_t>(d)]).transpose();
}

void LinearKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                            KernelScratch& /*scratch*/) const {
  int p = 0;
  if (bias_) grad(p++) += bias_value() * W.sum();
  for (size_t d = 0; d < columns_.size(); ++d, ++p) {
    const auto z = Z.col(columns_[d]);
    grad(p) += weight(static_cast<int>(d)) * z.dot(W * z);
  }
}

void LinearKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                                  Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& /*scratch*/) const {
  int p = 0;
  if (bias_) grad(p++) += bias_value() * W.sum();
  for (size_t d = 0; d < columns_.size(); ++d, ++p)
    grad(p) += weight(static_cast<int>(d)) * Z1.col(columns_[d]).dot(W * Z2.col(columns_[d]));
}

void LinearKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                       KernelScratch& /*scratch*/) const {
  out.setConstant(bias_value());
  for (size_t d = 0; d < columns_.size(); ++d)
    out.noalias() += (weight(static_cast<int>(d)) * z[columns_[d]]) * Z.col(columns_[d]);
}

double LinearKernel::self(const double* z, int /*feature_dim*/, KernelScratch& /*scratch*/) const {
  double k = bias_value();
  for (size_t d = 0; d < columns_.size(); ++d) k += weight(static_cast<int>(d)) * z[columns_[d]] * z[columns_[d]];
  return k;
}

}  // namespace gipdyn
