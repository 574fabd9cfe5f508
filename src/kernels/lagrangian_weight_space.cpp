#include "gipdyn/kernels/lagrangian_weight_space.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"

namespace gipdyn {

namespace {

constexpr int kMaxMonomials = 6;

int kinetic_size(bool revolute) { return revolute ? 6 : 3; }
int potential_size(bool revolute) { return revolute ? 3 : 2; }

// The monomials of LagrangianKernel::kinetic_monomial_weights (or, for the
// potential, its first 3 or 2) and their derivatives at q.
void joint_monomials(bool revolute, bool kinetic, double q, double* value, double* derivative) {
  if (!revolute) {
    value[0] = 1.0, value[1] = q, value[2] = q * q;
    derivative[0] = 0.0, derivative[1] = 1.0, derivative[2] = 2.0 * q;
    return;
  }
  const double c = std::cos(q), s = std::sin(q);
  value[0] = 1.0, value[1] = c, value[2] = s;
  derivative[0] = 0.0, derivative[1] = -s, derivative[2] = c;
  if (!kinetic) return;
  value[3] = c * c, value[4] = s * s, value[5] = c * s;
  derivative[3] = -2.0 * c * s, derivative[4] = 2.0 * c * s, derivative[5] = c * c - s * s;
}

// The next index of a product of one monomial per joint, joint 0's varying fastest.
void next_product(std::vector<int>& digits, const std::vector<int>& sizes) {
  for (size_t m = 0; m < digits.size(); ++m) {
    if (++digits[m] < sizes[m]) return;
    digits[m] = 0;
  }
}

}  // namespace

double LagrangianWeightSpaceMean::kinetic_monomials(const JointTypes& joints) {
  double count = 1.0;
  for (int m = 0; m < joints.size(); ++m) count *= kinetic_size(joints.is_revolute(m));
  return count;
}

bool LagrangianWeightSpaceMean::worthwhile(const JointTypes& joints, Eigen::Index rows) {
  const double n = joints.size(), pairs = n * (n + 1) / 2;
  const double F = kinetic_monomials(joints);
  // Weight space builds F products with their n gradients and multiplies them
  // by the pairs' weights, vectorised: about 0.25 ns an operation. Kernel
  // space builds one n x n block per training row: 40-50 ns per n^2 (BM_LipQuery*
  // in bench/RESULTS.md). Weight space must win by 2x to pay for building it.
  const double weight_space_ns = 0.25 * F * (3.0 * n + (n + 1.0) * pairs);
  const double kernel_space_ns = 40.0 * static_cast<double>(rows) * n * n;
  return 2.0 * weight_space_ns < kernel_space_ns;
}

LagrangianWeightSpaceMean::Workspace::Workspace(const LagrangianWeightSpaceMean& mean)
    : kinetic_features(mean.kinetic_count_, mean.n_ + 1),
      potential_features(mean.potential_count_, mean.n_ + 1),
      coefficients(static_cast<Eigen::Index>(mean.pairs_.size()), mean.n_ + 1),
      monomials(mean.n_, kMaxMonomials),
      derivatives(mean.n_, kMaxMonomials),
      digits(static_cast<size_t>(mean.n_)),
      prefix(static_cast<size_t>(mean.n_) + 1),
      suffix(static_cast<size_t>(mean.n_) + 1) {}

void LagrangianWeightSpaceMean::features(const double* q, bool kinetic, Workspace& w, Eigen::MatrixXd& out) const {
  const int n = n_;
  const std::vector<int>& size = kinetic ? kinetic_size_ : potential_size_;
  for (int m = 0; m < n; ++m) {
    double value[kMaxMonomials], derivative[kMaxMonomials];
    joint_monomials(kernel_.joints().is_revolute(m), kinetic, q[m], value, derivative);
    for (int k = 0; k < size[static_cast<size_t>(m)]; ++k) {
      w.monomials(m, k) = value[k];
      w.derivatives(m, k) = derivative[k];
    }
  }
  std::fill(w.digits.begin(), w.digits.end(), 0);
  for (Eigen::Index k = 0; k < out.rows(); ++k) {
    w.prefix[0] = 1.0;
    for (int m = 0; m < n; ++m) w.prefix[static_cast<size_t>(m) + 1] = w.prefix[static_cast<size_t>(m)] * w.monomials(m, w.digits[static_cast<size_t>(m)]);
    w.suffix[static_cast<size_t>(n)] = 1.0;
    for (int m = n; m-- > 0;) w.suffix[static_cast<size_t>(m)] = w.suffix[static_cast<size_t>(m) + 1] * w.monomials(m, w.digits[static_cast<size_t>(m)]);
    out(k, 0) = w.prefix[static_cast<size_t>(n)];
    for (int m = 0; m < n; ++m)
      out(k, m + 1) = w.prefix[static_cast<size_t>(m)] * w.derivatives(m, w.digits[static_cast<size_t>(m)]) *
                      w.suffix[static_cast<size_t>(m) + 1];
    next_product(w.digits, size);
  }
}

LagrangianWeightSpaceMean::LagrangianWeightSpaceMean(const LagrangianKernel& kernel, const Eigen::MatrixXd& X,
                                                     const Eigen::VectorXd& alpha)
    : kernel_(kernel), n_(kernel.joints().size()) {
  const int n = n_;
  if (X.cols() != 3 * n || alpha.size() != X.rows() * n)
    throw Error("LagrangianWeightSpaceMean: inconsistent shapes (training states or weights)");
  const double monomials = kinetic_monomials(kernel.joints());
  if (monomials > 4e6)
    throw Error("LagrangianWeightSpaceMean: " + std::to_string(monomials) + " monomials per coefficient for joints " +
                kernel.joints().str() + "; use the kernel-space mean");
  kinetic_count_ = potential_count_ = 1;
  for (int m = 0; m < n; ++m) {
    const bool revolute = kernel.joints().is_revolute(m);
    kinetic_size_.push_back(kinetic_size(revolute));
    potential_size_.push_back(potential_size(revolute));
    kinetic_count_ *= kinetic_size_.back();
    potential_count_ *= potential_size_.back();
  }
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) pairs_.emplace_back(a, b);
  const Eigen::Index P = static_cast<Eigen::Index>(pairs_.size());

  // cov(weights of h_ab, tau_j(x_r)) is lambda_ab times the monomials' prior
  // weights times the operator of the header applied to the monomials; summed
  // with alpha, three vectors per row: the monomials, their rate along qd and
  // their gradient along alpha_r.
  Workspace w(*this);
  kinetic_weights_.setZero(kinetic_count_, P);
  potential_weights_.setZero(potential_count_);
  if (kernel.has_friction()) friction_weights_.setZero(4, n);
  Eigen::MatrixXd along(kinetic_count_, 3), pair_coefficients(3, P);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const Eigen::VectorXd x = X.row(r).transpose();
    const auto q = x.head(n), qd = x.segment(n, n), qdd = x.segment(2 * n, n);
    const auto a = alpha.segment(r * n, n);
    features(q.data(), true, w, w.kinetic_features);
    along.col(0) = w.kinetic_features.col(0);
    along.col(1).noalias() = w.kinetic_features.rightCols(n) * qd;
    along.col(2).noalias() = w.kinetic_features.rightCols(n) * a;
    for (Eigen::Index p = 0; p < P; ++p) {
      const auto [i, j] = pairs_[static_cast<size_t>(p)];
      pair_coefficients(0, p) = a(i) * qdd(j) + a(j) * qdd(i);
      pair_coefficients(1, p) = a(i) * qd(j) + a(j) * qd(i);
      pair_coefficients(2, p) = -qd(i) * qd(j);
    }
    kinetic_weights_.noalias() += along * pair_coefficients;
    features(q.data(), false, w, w.potential_features);
    potential_weights_.noalias() += w.potential_features.rightCols(n) * a;
    for (int m = 0; m < n && kernel.has_friction(); ++m) {
      const Eigen::Vector4d f = kernel.friction_features_at(m, qd(m));
      for (int k = 0; k < 4; ++k) friction_weights_(k, m) += a(m) * f(k);
    }
  }

  // The prior weights of the monomial products, the same recursion on weights instead of values.
  auto prior = [&](bool kinetic, Eigen::Index count) {
    const std::vector<int>& size = kinetic ? kinetic_size_ : potential_size_;
    Eigen::VectorXd out(count);
    std::vector<int> digits(static_cast<size_t>(n), 0);
    Eigen::MatrixXd joint(n, kMaxMonomials);
    for (int m = 0; m < n; ++m) {
      double v[kMaxMonomials];
      kinetic ? kernel.kinetic_monomial_weights(m, v) : kernel.potential_monomial_weights(m, v);
      for (int k = 0; k < size[static_cast<size_t>(m)]; ++k) joint(m, k) = v[k];
    }
    for (Eigen::Index k = 0; k < count; ++k) {
      double product = 1.0;
      for (int m = 0; m < n; ++m) product *= joint(m, digits[static_cast<size_t>(m)]);
      out(k) = product;
      next_product(digits, size);
    }
    return out;
  };
  const Eigen::VectorXd kinetic_prior = prior(true, kinetic_count_);
  for (Eigen::Index p = 0; p < P; ++p) {
    const auto [i, j] = pairs_[static_cast<size_t>(p)];
    kinetic_weights_.col(p) = kinetic_weights_.col(p).cwiseProduct(kinetic_prior) * kernel.velocity_weight(i, j);
  }
  potential_weights_ = potential_weights_.cwiseProduct(prior(false, potential_count_));
  for (int m = 0; m < n && kernel.has_friction(); ++m) {
    const Eigen::Vector4d s = kernel.friction_variances(m);
    for (int k = 0; k < 4; ++k) friction_weights_(k, m) *= s(k);
  }
}

void LagrangianWeightSpaceMean::mean(const double* x, Workspace& w, double* tau_out) const {
  const int n = n_;
  const Eigen::Map<const Eigen::VectorXd> qd(x + n, n), qdd(x + 2 * n, n);
  Eigen::Map<Eigen::VectorXd> tau(tau_out, n);
  features(x, true, w, w.kinetic_features);
  // Each h_ab and its gradient in q at this state.
  w.coefficients.noalias() = kinetic_weights_.transpose() * w.kinetic_features;
  tau.setZero();
  for (size_t p = 0; p < pairs_.size(); ++p) {
    const auto [a, b] = pairs_[p];
    const auto row = w.coefficients.row(static_cast<Eigen::Index>(p));
    const double h = row(0);
    double rate = 0.0;
    for (int m = 0; m < n; ++m) rate += row(m + 1) * qd(m);
    tau(a) += qdd(b) * h + qd(b) * rate;
    tau(b) += qdd(a) * h + qd(a) * rate;
    const double velocities = qd(a) * qd(b);
    for (int i = 0; i < n; ++i) tau(i) -= velocities * row(i + 1);
  }
  features(x, false, w, w.potential_features);
  for (int i = 0; i < n; ++i) tau(i) += w.potential_features.col(i + 1).dot(potential_weights_);
  for (int m = 0; m < n && friction_weights_.size() > 0; ++m) {
    const Eigen::Vector4d f = kernel_.friction_features_at(m, qd(m));
    for (int k = 0; k < 4; ++k) tau(m) += friction_weights_(k, m) * f(k);
  }
}

Eigen::MatrixXd LagrangianWeightSpaceMean::mean(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  if (X.cols() != 3 * n_) throw Error("LagrangianWeightSpaceMean: states need " + std::to_string(3 * n_) + " columns");
  Workspace w(*this);
  Eigen::MatrixXd tau(X.rows(), n_);
  Eigen::VectorXd x(3 * n_), t(n_);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    x = X.row(r).transpose();
    mean(x.data(), w, t.data());
    tau.row(r) = t.transpose();
  }
  return tau;
}

}  // namespace gipdyn
