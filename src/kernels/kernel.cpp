#include "gipdyn/kernels/kernel.hpp"

namespace gipdyn {

void Kernel::gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& /*scratch*/) const {
  cross(Z, Z, K);
}

void Kernel::contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                          Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  Eigen::MatrixXd& W = scratch.c;
  W.resize(Z.rows(), Z.rows());
  W.triangularView<Eigen::Lower>() = Kinv_lower.triangularView<Eigen::Lower>();
  W.triangularView<Eigen::StrictlyUpper>() = Kinv_lower.transpose().triangularView<Eigen::StrictlyUpper>();
  W = alpha * alpha.transpose() - W;
  contract(Z, W, grad, scratch);
}

void Kernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                 KernelScratch& /*scratch*/) const {
  const Eigen::MatrixXd zq = Eigen::Map<const Eigen::RowVectorXd>(z, Z.cols());
  Eigen::MatrixXd K;
  cross(zq, Z, K);
  out = K.row(0).transpose();
}

double Kernel::self(const double* z, int feature_dim) const {
  const Eigen::MatrixXd zq = Eigen::Map<const Eigen::RowVectorXd>(z, feature_dim);
  Eigen::VectorXd d;
  diagonal(zq, d);
  return d(0);
}

}  // namespace gipdyn
