#include "gipdyn/kernels/lagrangian_weight_space.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/error.hpp"

namespace gipdyn {

namespace {

constexpr int kMaxBasis = 5;

int kinetic_size(bool revolute) { return revolute ? 5 : 3; }
int potential_size(bool revolute) { return revolute ? 3 : 2; }

// Joint m's basis functions and their derivatives at q. The kinetic factor
// pair's monomials (LagrangianKernel::kinetic_monomial_weights) of a revolute
// joint, 1, cos, sin, cos^2, sin^2, cos sin, span only five functions
// (cos^2 + sin^2 = 1): 1, cos, sin, cos 2q, sin 2q. A prismatic joint's are
// 1, q, q^2; the potential's 1, cos, sin or 1, q.
void joint_basis(bool revolute, bool kinetic, double q, double* value, double* derivative) {
  if (!revolute) {
    value[0] = 1.0, value[1] = q, value[2] = q * q;
    derivative[0] = 0.0, derivative[1] = 1.0, derivative[2] = 2.0 * q;
    return;
  }
  const double c = std::cos(q), s = std::sin(q);
  value[0] = 1.0, value[1] = c, value[2] = s;
  derivative[0] = 0.0, derivative[1] = -s, derivative[2] = c;
  if (!kinetic) return;
  const double c2 = c * c - s * s, s2 = 2.0 * c * s;
  value[3] = c2, value[4] = s2;
  derivative[3] = -2.0 * s2, derivative[4] = 2.0 * c2;
}

// The prior covariance of joint m's basis weights: its factor is
// sum_k w_k u_k(q) u_k(q') over monomials u = T b of the basis b, so
// the covariance is T' diag(w) T.
Eigen::MatrixXd joint_prior(const LagrangianKernel& kernel, int m, bool kinetic) {
  double w[6];
  const bool revolute = kernel.joints().is_revolute(m);
  if (!kinetic) {
    kernel.potential_monomial_weights(m, w);
    return Eigen::Map<const Eigen::VectorXd>(w, potential_size(revolute)).asDiagonal();
  }
  kernel.kinetic_monomial_weights(m, w);
  if (!revolute) return Eigen::Map<const Eigen::VectorXd>(w, 3).asDiagonal();
  Eigen::Matrix<double, 6, 5> T = Eigen::Matrix<double, 6, 5>::Zero();
  T(0, 0) = T(1, 1) = T(2, 2) = 1.0;             // 1, cos, sin
  T(3, 0) = 0.5, T(3, 3) = 0.5;                  // cos^2 = (1 + cos 2q) / 2
  T(4, 0) = 0.5, T(4, 3) = -0.5;                 // sin^2 = (1 - cos 2q) / 2
  T(5, 4) = 0.5;                                 // cos sin = sin 2q / 2
  return T.transpose() * Eigen::Map<const Eigen::Matrix<double, 6, 1>>(w).asDiagonal() * T;
}

// A <- (G_{n-1} kron ... kron G_0) A: the rows of A are indexed like the basis
// products (joint 0 fastest), G[m] acts on joint m's index.
template <class Matrix>
void multiply_per_joint(const std::vector<Eigen::MatrixXd>& G, Matrix& A) {
  Eigen::Index stride = 1;
  Eigen::VectorXd in, out;
  for (const Eigen::MatrixXd& Gm : G) {
    const Eigen::Index d = Gm.rows(), outer = A.rows() / (stride * d);
    in.resize(d);
    for (Eigen::Index c = 0; c < A.cols(); ++c)
      for (Eigen::Index o = 0; o < outer; ++o)
        for (Eigen::Index u = 0; u < stride; ++u) {
          for (Eigen::Index i = 0; i < d; ++i) in(i) = A(u + stride * (i + d * o), c);
          out.noalias() = Gm * in;
          for (Eigen::Index i = 0; i < d; ++i) A(u + stride * (i + d * o), c) = out(i);
        }
    stride *= d;
  }
}

// One joint's step of a contraction: in holds `columns` columns of D-row
// blocks (outer of them, the joint's basis index fastest); column j of out
// gets each block times the basis values b, and column columns + j, for the
// first value_columns columns, times their derivatives db. out: outer x
// (columns + value_columns).
template <int D>
void contract_blocks(const double* in, Eigen::Index outer, Eigen::Index columns, Eigen::Index value_columns,
                     const double* b, const double* db, double* out) {
  for (Eigen::Index j = 0; j < columns; ++j) {
    const double* block = in + j * outer * D;
    double* value = out + j * outer;
    if (j < value_columns) {
      double* derivative = out + (columns + j) * outer;
      for (Eigen::Index o = 0; o < outer; ++o, block += D) {
        double v = 0.0, g = 0.0;
        for (int i = 0; i < D; ++i) v += b[i] * block[i], g += db[i] * block[i];
        value[o] = v, derivative[o] = g;
      }
    } else {
      for (Eigen::Index o = 0; o < outer; ++o, block += D) {
        double v = 0.0;
        for (int i = 0; i < D; ++i) v += b[i] * block[i];
        value[o] = v;
      }
    }
  }
}

// What LagrangianWeightSpaceMean::contract() does with `columns` columns of
// weights over joints first_joint..n - 1 of these basis sizes: its
// multiply-adds, and its largest intermediate (after joint m, the rows of the
// joints past m times a column per weight column for the value and each
// derivative so far).
struct ContractionCost {
  double multiply_adds = 0.0;
  Eigen::Index largest = 1;
};
ContractionCost contraction_cost(const std::vector<int>& size, int first_joint, Eigen::Index columns) {
  ContractionCost cost;
  Eigen::Index rows = 1, width = columns;
  for (size_t m = static_cast<size_t>(first_joint); m < size.size(); ++m) rows *= size[m];
  for (size_t m = static_cast<size_t>(first_joint); m < size.size(); ++m) {
    cost.multiply_adds += static_cast<double>(rows) * static_cast<double>(width + columns);
    rows /= size[m], width += columns;
    cost.largest = std::max(cost.largest, rows * width);
  }
  return cost;
}

// The kinetic weights' blocks a query contracts: (first joint, columns) of
// each. All pairs' weights over every joint; on a serial chain, h_ab's for one
// a at a time over joints a + 1..n - 1 (LagrangianWeightSpaceMean::term_weights_).
std::vector<std::pair<int, Eigen::Index>> kinetic_terms(bool serial_chain, int n) {
  if (!serial_chain) return {{0, n * (n + 1) / 2}};
  std::vector<std::pair<int, Eigen::Index>> terms;
  for (int a = 0; a < n; ++a) terms.emplace_back(a + 1, n - a);
  return terms;
}

// Basis functions per joint of the kinetic or the potential energy's weights.
std::vector<int> basis_sizes(const JointTypes& joints, bool kinetic) {
  std::vector<int> sizes;
  for (int m = 0; m < joints.size(); ++m)
    sizes.push_back(kinetic ? kinetic_size(joints.is_revolute(m)) : potential_size(joints.is_revolute(m)));
  return sizes;
}

double product(const std::vector<int>& sizes) {
  double count = 1.0;
  for (int size : sizes) count *= size;
  return count;
}

}  // namespace

double LagrangianWeightSpaceMean::kinetic_basis_size(const JointTypes& joints) {
  return product(basis_sizes(joints, true));
}

bool LagrangianWeightSpaceMean::worthwhile(const LagrangianKernel& kernel, Eigen::Index rows) {
  const JointTypes& joints = kernel.joints();
  const int n = joints.size();
  const double pairs = n * (n + 1) / 2.0, N = static_cast<double>(rows);
  const double F = kinetic_basis_size(joints);
  if (F > 4e6) return false;  // (the constructor refuses it)
  const std::vector<int> kinetic = basis_sizes(joints, true), potential = basis_sizes(joints, false);
  double multiply_adds = contraction_cost(potential, 0, 1).multiply_adds;
  for (const auto& [first, columns] : kinetic_terms(kernel.serial_chain(), n))
    multiply_adds += contraction_cost(kinetic, first, columns).multiply_adds;
  // A weight-space query contracts the weights with the basis, about 0.25 ns
  // per multiply-add; a kernel-space one builds an n x n block per training
  // row, about 40 ns per n^2 (60 on a serial chain, whose blocks are sums of n
  // terms) (BM_LipQuery* in bench/RESULTS.md). Weight space must win by 2x,
  // and building it (N F (3 pairs + 2 (n + 1)) operations) must take seconds at most.
  const double weight_space_ns = 0.25 * multiply_adds;
  const double kernel_space_ns = (kernel.serial_chain() ? 60.0 : 40.0) * N * n * n;
  const double build_operations = N * F * (3.0 * pairs + 2.0 * (n + 1.0));
  return 2.0 * weight_space_ns < kernel_space_ns && build_operations < 3e10;
}

LagrangianWeightSpaceMean::Workspace::Workspace(const LagrangianWeightSpaceMean& mean)
    : coefficients(static_cast<Eigen::Index>(mean.pairs_.size()), mean.n_ + 1), potential(1, mean.n_ + 1), q(mean.n_) {
  Eigen::Index largest = contraction_cost(mean.potential_size_, 0, 1).largest;
  for (const auto& [first, columns] : kinetic_terms(!mean.term_weights_.empty(), mean.n_))
    largest = std::max(largest, contraction_cost(mean.kinetic_size_, first, columns).largest);
  for (Eigen::VectorXd& buffer : contraction) buffer.resize(largest);
}

void LagrangianWeightSpaceMean::features(const double* q, bool kinetic, Eigen::MatrixXd& out) const {
  const int n = n_;
  const std::vector<int>& size = kinetic ? kinetic_size_ : potential_size_;
  // Joint by joint, as Kronecker products: after joint m the first len rows
  // hold the products over joints 0..m, and column m + 1 (the derivative in
  // q_m) is the only new non-zero column. Block i of the next len * d rows is
  // the first block times joint m's basis function i (its derivative in
  // column m + 1); block 0 is done last, in place.
  out(0, 0) = 1.0;
  Eigen::Index len = 1;
  for (int m = 0; m < n; ++m) {
    double value[kMaxBasis], derivative[kMaxBasis];
    joint_basis(kernel_.joints().is_revolute(m), kinetic, q[m], value, derivative);
    const int d = size[static_cast<size_t>(m)];
    const Eigen::Index cols = m + 2;  // columns past it are still zero
    for (int i = d - 1; i > 0; --i) {
      out.block(i * len, 0, len, cols) = value[i] * out.block(0, 0, len, cols);
      out.block(i * len, m + 1, len, 1) = derivative[i] * out.block(0, 0, len, 1);
    }
    out.block(0, m + 1, len, 1) = derivative[0] * out.block(0, 0, len, 1);
    out.block(0, 0, len, m + 1) *= value[0];
    len *= d;
  }
}

LagrangianWeightSpaceMean::LagrangianWeightSpaceMean(const LagrangianKernel& kernel, const Eigen::MatrixXd& X,
                                                     const Eigen::VectorXd& alpha)
    : kernel_(kernel), n_(kernel.joints().size()) {
  // Its products here and in every query: on one thread, as the library's others.
  use_single_threaded_blas();
  const int n = n_;
  if (X.cols() != 3 * n || alpha.size() != X.rows() * n)
    throw Error("LagrangianWeightSpaceMean: inconsistent shapes (training states or weights)");
  const double basis = kinetic_basis_size(kernel.joints());
  if (basis > 4e6)
    throw Error("LagrangianWeightSpaceMean: " + std::to_string(basis) + " basis functions per coefficient for joints " +
                kernel.joints().str() + "; use the kernel-space mean");
  kinetic_size_ = basis_sizes(kernel.joints(), true);
  potential_size_ = basis_sizes(kernel.joints(), false);
  kinetic_count_ = static_cast<Eigen::Index>(product(kinetic_size_));
  potential_count_ = static_cast<Eigen::Index>(product(potential_size_));
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) pairs_.emplace_back(a, b);
  const Eigen::Index P = static_cast<Eigen::Index>(pairs_.size());

  // cov(weights of h_ab, tau_j(x_r)) is the weights' prior covariance times
  // the operator of the header applied to the basis; summed with alpha, three
  // vectors per row: the basis products, their rate along qd and their
  // gradient along alpha_r.
  Eigen::MatrixXd kinetic_features(kinetic_count_, n + 1), potential_features(potential_count_, n + 1);
  kinetic_weights_.setZero(kinetic_count_, P);
  potential_weights_.setZero(potential_count_, 1);
  if (kernel.has_friction()) friction_weights_.setZero(4, n);
  // Rows in blocks, so that the sum is one matrix product a block (not a
  // rank-3 update of the whole F x pairs matrix a row).
  constexpr Eigen::Index kBlock = 32;
  Eigen::MatrixXd along(kinetic_count_, 3 * kBlock), pair_coefficients(3 * kBlock, P);
  for (Eigen::Index r0 = 0; r0 < X.rows(); r0 += kBlock) {
    const Eigen::Index rows = std::min(kBlock, X.rows() - r0);
    for (Eigen::Index b = 0; b < rows; ++b) {
      const Eigen::Index r = r0 + b;
      const Eigen::VectorXd x = X.row(r).transpose();
      const auto q = x.head(n), qd = x.segment(n, n), qdd = x.segment(2 * n, n);
      const auto a = alpha.segment(r * n, n);
      features(q.data(), true, kinetic_features);
      along.col(3 * b) = kinetic_features.col(0);
      along.col(3 * b + 1).noalias() = kinetic_features.rightCols(n) * qd;
      along.col(3 * b + 2).noalias() = kinetic_features.rightCols(n) * a;
      for (Eigen::Index p = 0; p < P; ++p) {
        const auto [i, j] = pairs_[static_cast<size_t>(p)];
        pair_coefficients(3 * b, p) = a(i) * qdd(j) + a(j) * qdd(i);
        pair_coefficients(3 * b + 1, p) = a(i) * qd(j) + a(j) * qd(i);
        pair_coefficients(3 * b + 2, p) = -qd(i) * qd(j);
      }
      features(q.data(), false, potential_features);
      potential_weights_.noalias() += potential_features.rightCols(n) * a;
      for (int m = 0; m < n && kernel.has_friction(); ++m) {
        const Eigen::Vector4d f = kernel.friction_features_at(m, qd(m));
        for (int k = 0; k < 4; ++k) friction_weights_(k, m) += a(m) * f(k);
      }
    }
    kinetic_weights_.noalias() += along.leftCols(3 * rows) * pair_coefficients.topRows(3 * rows);
  }

  // Times the prior covariance of the weights: lambda_ab times each joint's factor's.
  std::vector<Eigen::MatrixXd> kinetic_prior, potential_prior;
  for (int m = 0; m < n; ++m) {
    kinetic_prior.push_back(joint_prior(kernel, m, true));
    potential_prior.push_back(joint_prior(kernel, m, false));
  }
  auto scale_by_velocity_weights = [&](Eigen::Index first, Eigen::Index count) {
    for (Eigen::Index p = first; p < first + count; ++p) {
      const auto [i, j] = pairs_[static_cast<size_t>(p)];
      kinetic_weights_.col(p) *= kernel.velocity_weight(i, j);
    }
  };
  if (!kernel.serial_chain()) {
    multiply_per_joint(kinetic_prior, kinetic_weights_);
    scale_by_velocity_weights(0, P);
  } else {
    // On a serial chain h_ab's factors before joint a + 1 are 1: the constant
    // basis function with weight 1. So its weights vanish but in the rows
    // r * stride (joints 0..a at their constant function), which term_weights_
    // keeps. The pairs (a, b) of one a are adjacent columns.
    Eigen::Index stride = 1;
    for (int a = 0, column = 0; a < n; column += n - a, ++a) {
      std::vector<Eigen::MatrixXd> prior = kinetic_prior;
      for (int m = 0; m < kernel.first_kinetic_joint(a); ++m) {
        prior[static_cast<size_t>(m)].setZero();
        prior[static_cast<size_t>(m)](0, 0) = 1.0;
      }
      auto columns = kinetic_weights_.middleCols(column, n - a);
      multiply_per_joint(prior, columns);
      scale_by_velocity_weights(column, n - a);
      stride *= kinetic_size_[static_cast<size_t>(a)];
      const Eigen::Index rows = kinetic_count_ / stride;
      Eigen::MatrixXd weights(rows, n - a);
      for (Eigen::Index r = 0; r < rows; ++r) weights.row(r) = kinetic_weights_.block(r * stride, column, 1, n - a);
      term_weights_.push_back(std::move(weights));
    }
    kinetic_weights_.resize(0, 0);  // the other rows are zeros
  }
  multiply_per_joint(potential_prior, potential_weights_);
  for (int m = 0; m < n && kernel.has_friction(); ++m) {
    const Eigen::Vector4d s = kernel.friction_variances(m);
    for (int k = 0; k < 4; ++k) friction_weights_(k, m) *= s(k);
  }
}

void LagrangianWeightSpaceMean::contract(const double* q, bool kinetic, const Eigen::MatrixXd& weights, int first_joint,
                                         Workspace& w, Eigen::Ref<Eigen::MatrixXd> out) const {
  // sum_k W_k phi_k(q) with phi_k the products of one basis function per
  // joint: joint by joint, the fastest index first, each step summing d rows
  // into one, with the basis values for the value and every derivative so far,
  // and with the derivatives for the value's new derivative. O(F c) for F rows
  // and c columns, where building the F products and their n gradients and
  // multiplying them with the weights costs O(F n c).
  const std::vector<int>& size = kinetic ? kinetic_size_ : potential_size_;
  const Eigen::Index c = weights.cols();
  const double* in = weights.data();
  Eigen::Index rows = weights.rows(), columns = c;
  int next = 0;
  for (int m = first_joint; m < n_; ++m) {
    double value[kMaxBasis] = {}, derivative[kMaxBasis] = {};
    joint_basis(kernel_.joints().is_revolute(m), kinetic, q[m], value, derivative);
    double* step = w.contraction[static_cast<size_t>(next)].data();
    const int d = size[static_cast<size_t>(m)];
    const Eigen::Index outer = rows / d;
    switch (d) {
      case 2: contract_blocks<2>(in, outer, columns, c, value, derivative, step); break;
      case 3: contract_blocks<3>(in, outer, columns, c, value, derivative, step); break;
      default: contract_blocks<kMaxBasis>(in, outer, columns, c, value, derivative, step); break;
    }
    in = step, rows = outer, columns += c, next ^= 1;
  }
  // One row left: the value's columns, then each derivative's, joint first_joint's first.
  out.setZero();
  out.col(0) = Eigen::Map<const Eigen::VectorXd>(in, c);
  for (int m = first_joint; m < n_; ++m)
    out.col(m + 1) = Eigen::Map<const Eigen::VectorXd>(in + (m - first_joint + 1) * c, c);
}

void LagrangianWeightSpaceMean::mean(const double* x, Workspace& w, double* tau_out) const {
  const int n = n_;
  const Eigen::Map<const Eigen::VectorXd> qd(x + n, n), qdd(x + 2 * n, n);
  Eigen::Map<Eigen::VectorXd> tau(tau_out, n);
  const Eigen::Map<const Eigen::VectorXd> q(x, n);
  if (!w.cached_q || w.q != q) {  // (a NaN never equals: computed again)
    // Each h_ab and its gradient in q at this state.
    if (term_weights_.empty()) {
      contract(x, true, kinetic_weights_, 0, w, w.coefficients);
    } else {  // (the order of kinetic_terms(), without its allocation)
      for (int a = 0, row = 0; a < n; row += n - a, ++a)
        contract(x, true, term_weights_[static_cast<size_t>(a)], a + 1, w, w.coefficients.middleRows(row, n - a));
    }
    contract(x, false, potential_weights_, 0, w, w.potential);
    w.q = q;
    w.cached_q = true;
  }
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
  tau += w.potential.row(0).tail(n).transpose();
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
