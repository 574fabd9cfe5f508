#include "gipdyn/kernels/kernel.hpp"

#include <atomic>

#include <algorithm>

namespace gipdyn {

std::uint64_t Kernel::next_instance() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

void Kernel::gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& /*scratch*/) const {
  cross(Z, Z, K);
}

void Kernel::nll_weights(const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower, Eigen::MatrixXd& W) {
  const Eigen::Index N = alpha.size();
  W.resize(N, N);
  W.triangularView<Eigen::Lower>() = Kinv_lower.triangularView<Eigen::Lower>();
  W.triangularView<Eigen::StrictlyUpper>() = Kinv_lower.transpose().triangularView<Eigen::StrictlyUpper>();
  // In place: `alpha * alpha^T - W` would first evaluate the outer product into an N x N temporary.
  W = -W;
  W.noalias() += alpha * alpha.transpose();
}

void Kernel::contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                          Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  nll_weights(alpha, Kinv_lower, scratch.c);
  contract(Z, scratch.c, grad, scratch);
}

void Kernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                 KernelScratch& /*scratch*/) const {
  const Eigen::MatrixXd zq = Eigen::Map<const Eigen::RowVectorXd>(z, Z.cols());
  Eigen::MatrixXd K;
  cross(zq, Z, K);
  out = K.row(0).transpose();
}

void Kernel::plan_mean(const Eigen::MatrixXd& /*Z*/, const Eigen::VectorXd& /*alpha*/, MeanPlan& plan) const {
  plan = MeanPlan{};
}

double Kernel::mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha,
                        const MeanPlan& /*plan*/, Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const {
  row(z, Z, krow, scratch);
  return krow.dot(alpha);
}

void Kernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                            Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  const Eigen::Index n1 = Z1.rows(), n2 = Z2.rows();
  Eigen::MatrixXd stacked(n1 + n2, Z1.cols());
  stacked << Z1, Z2;
  Eigen::MatrixXd& S = scratch.c;
  S.setZero(n1 + n2, n1 + n2);
  S.topRightCorner(n1, n2) = 0.5 * W;
  S.bottomLeftCorner(n2, n1) = 0.5 * W.transpose();
  contract(stacked, S, grad, scratch);
}

void Kernel::contract_diagonal(const Eigen::MatrixXd& Z, const Eigen::VectorXd& w, Eigen::Ref<Eigen::VectorXd> grad,
                               KernelScratch& scratch) const {
  constexpr Eigen::Index kBlock = 16;  // the off-diagonal entries of a block are wasted work
  Eigen::MatrixXd& D = scratch.c;
  for (Eigen::Index i0 = 0; i0 < Z.rows(); i0 += kBlock) {
    const Eigen::Index m = std::min(kBlock, Z.rows() - i0);
    D.setZero(m, m);
    D.diagonal() = w.segment(i0, m);
    contract(Z.middleRows(i0, m), D, grad, scratch);
  }
}

double Kernel::self(const double* z, int feature_dim, KernelScratch& /*scratch*/) const {
  const Eigen::MatrixXd zq = Eigen::Map<const Eigen::RowVectorXd>(z, feature_dim);
  Eigen::VectorXd d;
  diagonal(zq, d);
  return d(0);
}

}  // namespace gipdyn
