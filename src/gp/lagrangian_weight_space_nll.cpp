#include "gipdyn/gp/lagrangian_weight_space_nll.hpp"

#include <lapacke.h>

#include <array>
#include <cmath>
#include <string>

#include "gipdyn/error.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/kernels/friction_kernel.hpp"

namespace gipdyn {

namespace {

// Beyond this many features the n per-joint r x r products and the r x r
// inverse cost more memory than a weight-space evaluation saves.
constexpr double kMaxFeatures = 2000.0;
constexpr int kMaxMonomials = 6;
// Below this reciprocal condition number of A, the rounding of its r x r
// products (about 1e-16 / rcond, absolute) approaches its identity part, the
// noise: kernel space, whose factorisation fails there and adds jitter, is the
// one to evaluate. On simulated SCARA logs a few of a fit's evaluations cross it.
constexpr double kMinReciprocalCondition = 1e-13;
using Monomials = std::array<double, kMaxMonomials>;

int factor_size(bool revolute) { return revolute ? 3 : 2; }
int kinetic_monomials(bool revolute) { return revolute ? 6 : 3; }
int potential_monomials(bool revolute) { return revolute ? 3 : 2; }

// The monomial z_i z_j of terms i and j of a joint's two kinetic factors
// (z = 1, cos, sin of a revolute joint, 1, q of a prismatic one), in the order
// of LagrangianKernel::kinetic_monomial_weights: 1, cos, sin, cos^2, sin^2,
// cos sin, or 1, q, q^2.
int product_monomial(bool revolute, int i, int j) {
  static constexpr int kRevolute[3][3] = {{0, 1, 2}, {1, 3, 5}, {2, 5, 4}};
  return revolute ? kRevolute[i][j] : i + j;
}

// A joint's kinetic monomials and their derivatives at q.
void kinetic_basis(bool revolute, double q, Monomials& value, Monomials& derivative) {
  if (!revolute) {
    value = {1.0, q, q * q};
    derivative = {0.0, 1.0, 2.0 * q};
    return;
  }
  const double c = std::cos(q), s = std::sin(q);
  value = {1.0, c, s, c * c, s * s, c * s};
  derivative = {0.0, -s, c, -2.0 * c * s, 2.0 * c * s, c * c - s * s};
}

// A joint's potential monomials (1, cos, sin or 1, q) and their derivatives at q.
void potential_basis(bool revolute, double q, Monomials& value, Monomials& derivative) {
  if (!revolute) {
    value = {1.0, q};
    derivative = {0.0, 1.0};
    return;
  }
  value = {1.0, std::cos(q), std::sin(q)};
  derivative = {0.0, -std::sin(q), std::cos(q)};
}

// Every product of one index per joint (sizes[k] choices for the k-th), the first varying fastest.
Eigen::MatrixXi index_products(const std::vector<int>& sizes) {
  Eigen::Index count = 1;
  for (int s : sizes) count *= s;
  Eigen::MatrixXi out(count, static_cast<Eigen::Index>(sizes.size()));
  for (Eigen::Index p = 0; p < count; ++p) {
    Eigen::Index rest = p;
    for (size_t k = 0; k < sizes.size(); ++k) {
      out(p, static_cast<Eigen::Index>(k)) = static_cast<int>(rest % sizes[k]);
      rest /= sizes[k];
    }
  }
  return out;
}

// A product of one basis function per listed joint: its value and its
// gradient in q (all n entries; zero for the joints not listed).
double basis_product(const std::vector<int>& joints, const Eigen::MatrixXi& monomials, Eigen::Index p,
                     const std::vector<Monomials>& value, const std::vector<Monomials>& derivative,
                     Eigen::VectorXd& gradient) {
  gradient.setZero();
  double u = 1.0;
  const Eigen::Index J = static_cast<Eigen::Index>(joints.size());
  for (Eigen::Index k = 0; k < J; ++k) u *= value[static_cast<size_t>(joints[static_cast<size_t>(k)])][static_cast<size_t>(monomials(p, k))];
  for (Eigen::Index k = 0; k < J; ++k) {
    double g = 1.0;
    for (Eigen::Index l = 0; l < J; ++l) {
      const auto m = static_cast<size_t>(joints[static_cast<size_t>(l)]);
      const auto i = static_cast<size_t>(monomials(p, l));
      g *= l == k ? derivative[m][i] : value[m][i];
    }
    gradient(joints[static_cast<size_t>(k)]) = g;
  }
  return u;
}

}  // namespace

double LagrangianWeightSpaceNll::feature_count(const LagrangianKernel& kernel) {
  const JointTypes& joints = kernel.joints();
  const int n = joints.size();
  double count = 0.0;
  const int terms = kernel.serial_chain() ? n : 1;
  for (int t = 0; t < terms; ++t) {
    double products = 1.0;
    for (int m = kernel.first_kinetic_joint(t); m < n; ++m) products *= kinetic_monomials(joints.is_revolute(m));
    count += products * (kernel.serial_chain() ? n - t : n * (n + 1) / 2.0);
  }
  double potential = 1.0;
  for (int m = 0; m < n; ++m) potential *= potential_monomials(joints.is_revolute(m));
  return count + potential + (kernel.has_friction() ? 4.0 * n : 0.0);
}

bool LagrangianWeightSpaceNll::worthwhile(const LagrangianKernel& kernel, Eigen::Index rows) {
  const double features = feature_count(kernel);
  return features <= kMaxFeatures && features < static_cast<double>(rows) * kernel.joints().size();
}

double LagrangianWeightSpaceNll::bytes(const LagrangianKernel& kernel, Eigen::Index rows) {
  const double r = feature_count(kernel), n = kernel.joints().size(), N = static_cast<double>(rows);
  return 8.0 * n * (r * N + r * r + 3.0 * N);
}

double LagrangianWeightSpaceNll::evaluation_bytes(const LagrangianKernel& kernel, Eigen::Index rows) {
  const double r = feature_count(kernel), n = kernel.joints().size(), N = static_cast<double>(rows);
  return 8.0 * (4.0 * r * r + 13.0 * n * N + 8.0 * r);
}

LagrangianWeightSpaceNll::LagrangianWeightSpaceNll(const LagrangianKernel& kernel, const Eigen::MatrixXd& X,
                                                   const Eigen::VectorXd& y)
    : n_(kernel.joints().size()), rows_(X.rows()), serial_chain_(kernel.serial_chain()),
      friction_(kernel.has_friction()) {
  const int n = n_;
  if (X.cols() != 3 * n || y.size() != X.rows() * n)
    throw Error("LagrangianWeightSpaceNll: inconsistent shapes (states or torques)");
  const double count = feature_count(kernel);
  if (count > kMaxFeatures)
    throw Error("LagrangianWeightSpaceNll: " + std::to_string(static_cast<long>(count)) + " features for joints " +
                kernel.joints().str() + "; use the kernel-space likelihood");
  for (int m = 0; m < n; ++m) revolute_.push_back(kernel.joints().is_revolute(m));

  // The kinetic terms and their columns; lambda_ab's parameter index runs over a <= b, b fastest.
  auto pair_param = [n](int a, int b) { return a * n - a * (a - 1) / 2 + (b - a); };
  Eigen::Index column = 0;
  for (int t = 0; t < (serial_chain_ ? n : 1); ++t) {
    Term term;
    std::vector<int> sizes;
    for (int m = kernel.first_kinetic_joint(t); m < n; ++m) {
      term.joints.push_back(m);
      sizes.push_back(kinetic_monomials(revolute_[static_cast<size_t>(m)]));
    }
    term.monomials = index_products(sizes);
    for (int a = serial_chain_ ? t : 0; a < (serial_chain_ ? t + 1 : n); ++a)
      for (int b = a; b < n; ++b) {
        term.pairs.emplace_back(a, b);
        term.pair_params.push_back(pair_param(a, b));
      }
    term.column = column;
    column += static_cast<Eigen::Index>(term.pairs.size()) * term.monomials.rows();
    terms_.push_back(std::move(term));
  }
  std::vector<int> potential_sizes, all_joints;
  for (int m = 0; m < n; ++m) {
    potential_sizes.push_back(potential_monomials(revolute_[static_cast<size_t>(m)]));
    all_joints.push_back(m);
  }
  potential_monomials_ = index_products(potential_sizes);
  potential_column_ = column;
  energy_features_ = column + potential_monomials_.rows();
  friction_features_ = friction_ ? 4 * n : 0;
  velocities_ = X.middleCols(n, n);

  // The torques of each feature at every state (the header's operator, feature by feature).
  phi_.assign(static_cast<size_t>(n), Eigen::MatrixXd::Zero(energy_features_, rows_));
  std::vector<Monomials> kv(static_cast<size_t>(n)), kd(static_cast<size_t>(n)), pv(static_cast<size_t>(n)),
      pd(static_cast<size_t>(n));
  Eigen::VectorXd gradient(n);
  for (Eigen::Index r = 0; r < rows_; ++r) {
    const Eigen::VectorXd x = X.row(r).transpose();
    const auto q = x.head(n), qd = x.segment(n, n), qdd = x.segment(2 * n, n);
    for (int m = 0; m < n; ++m) {
      kinetic_basis(revolute_[static_cast<size_t>(m)], q(m), kv[static_cast<size_t>(m)], kd[static_cast<size_t>(m)]);
      potential_basis(revolute_[static_cast<size_t>(m)], q(m), pv[static_cast<size_t>(m)], pd[static_cast<size_t>(m)]);
    }
    for (const Term& term : terms_) {
      const Eigen::Index products = term.monomials.rows();
      for (Eigen::Index p = 0; p < products; ++p) {
        const double u = basis_product(term.joints, term.monomials, p, kv, kd, gradient);
        const double rate = gradient.dot(qd);  // du/dt
        for (size_t pi = 0; pi < term.pairs.size(); ++pi) {
          const auto [a, b] = term.pairs[pi];
          const Eigen::Index col = term.column + static_cast<Eigen::Index>(pi) * products + p;
          // tau_i of qd_a qd_b u(q): d/dt dT/dqd_i - dT/dq_i.
          for (int i = 0; i < n; ++i) phi_[static_cast<size_t>(i)](col, r) = -qd(a) * qd(b) * gradient(i);
          phi_[static_cast<size_t>(a)](col, r) += qdd(b) * u + qd(b) * rate;
          phi_[static_cast<size_t>(b)](col, r) += qdd(a) * u + qd(a) * rate;
        }
      }
    }
    for (Eigen::Index p = 0; p < potential_monomials_.rows(); ++p) {
      basis_product(all_joints, potential_monomials_, p, pv, pd, gradient);
      for (int i = 0; i < n; ++i) phi_[static_cast<size_t>(i)](potential_column_ + p, r) = gradient(i);
    }
  }
  for (int i = 0; i < n; ++i) {
    const auto ui = static_cast<size_t>(i);
    Eigen::MatrixXd& gram = gram_.emplace_back(Eigen::MatrixXd::Zero(energy_features_, energy_features_));
    gram.selfadjointView<Eigen::Lower>().rankUpdate(phi_[ui]);
    gram.triangularView<Eigen::StrictlyUpper>() = gram.transpose();
    Eigen::VectorXd yi(rows_);
    for (Eigen::Index r = 0; r < rows_; ++r) yi(r) = y(r * n + i);
    phi_y_.emplace_back(phi_[ui] * yi);
    y_.push_back(std::move(yi));
  }
}

void LagrangianWeightSpaceNll::check_structure(const LagrangianKernel& kernel) const {
  bool same = kernel.joints().size() == n_ && kernel.serial_chain() == serial_chain_ &&
              kernel.has_friction() == friction_;
  for (int m = 0; same && m < n_; ++m) same = kernel.joints().is_revolute(m) == revolute_[static_cast<size_t>(m)];
  if (!same)
    throw Error("LagrangianWeightSpaceNll: the kernel's joints, serial chain or friction differ from those of its "
                "features");
}

NllEvaluation LagrangianWeightSpaceNll::evaluate(const LagrangianKernel& kernel, const Eigen::VectorXd& noise,
                                                 bool with_gradient, Eigen::VectorXd* alpha) const {
  check_structure(kernel);
  const int n = n_;
  if (noise.size() != n || !(noise.array() > 0.0).all())
    throw Error("LagrangianWeightSpaceNll: one positive noise variance per joint expected");
  const Eigen::Index N = rows_, rE = energy_features_, r = energy_features_ + friction_features_;
  const Eigen::VectorXd& lp = kernel.log_params();
  const int P = kernel.num_params();
  NllEvaluation e;

  // Each joint's monomial weights (logs) and, for the kinetic ones, their
  // derivatives in the log-parameters of its two factors.
  std::vector<int> kinetic_offset(static_cast<size_t>(n)), potential_offset(static_cast<size_t>(n));
  std::vector<Monomials> log_kinetic(static_cast<size_t>(n)), log_potential(static_cast<size_t>(n));
  std::vector<Eigen::Matrix<double, kMaxMonomials, kMaxMonomials>> kinetic_jacobian(static_cast<size_t>(n));
  int ko = kernel.kinetic_position_offset(), po = kernel.potential_offset();
  for (int m = 0; m < n; ++m) {
    const auto um = static_cast<size_t>(m);
    const bool rev = revolute_[um];
    const int fs = factor_size(rev);
    kinetic_offset[um] = ko;
    potential_offset[um] = po;
    Monomials w{};
    Eigen::Matrix<double, kMaxMonomials, kMaxMonomials> dw = Eigen::Matrix<double, kMaxMonomials, kMaxMonomials>::Zero();
    for (int i = 0; i < fs; ++i)
      for (int j = 0; j < fs; ++j) {
        const int k = product_monomial(rev, i, j);
        const double term = std::exp(lp(ko + i)) * std::exp(lp(ko + fs + j));
        w[static_cast<size_t>(k)] += term;
        dw(k, i) += term;
        dw(k, fs + j) += term;
      }
    for (int k = 0; k < kinetic_monomials(rev); ++k) {
      log_kinetic[um][static_cast<size_t>(k)] = std::log(w[static_cast<size_t>(k)]);
      kinetic_jacobian[um].row(k) = dw.row(k) / w[static_cast<size_t>(k)];
    }
    for (int k = 0; k < fs; ++k) log_potential[um][static_cast<size_t>(k)] = lp(po + k);
    ko += 2 * fs;
    po += fs;
  }

  // The features' log prior variances.
  Eigen::VectorXd log_s(r);
  for (const Term& term : terms_)
    for (size_t pi = 0; pi < term.pairs.size(); ++pi)
      for (Eigen::Index p = 0; p < term.monomials.rows(); ++p) {
        double v = lp(term.pair_params[pi]);
        for (size_t k = 0; k < term.joints.size(); ++k)
          v += log_kinetic[static_cast<size_t>(term.joints[k])][static_cast<size_t>(term.monomials(p, static_cast<Eigen::Index>(k)))];
        log_s(term.column + static_cast<Eigen::Index>(pi) * term.monomials.rows() + p) = v;
      }
  for (Eigen::Index p = 0; p < potential_monomials_.rows(); ++p) {
    double v = 0.0;
    for (int m = 0; m < n; ++m) v += log_potential[static_cast<size_t>(m)][static_cast<size_t>(potential_monomials_(p, m))];
    log_s(potential_column_ + p) = v;
  }
  const int fo = kernel.friction_offset();
  for (int m = 0; m < n && friction_; ++m)
    for (int k = 0; k < 4; ++k) log_s(rE + 4 * m + k) = lp(fo + FrictionKernel::kNumParams * m + k);
  const Eigen::VectorXd root_s = log_s.unaryExpr([](double v) { return std::exp(0.5 * v); });

  // Friction's features at this evaluation's velocities, and their derivatives
  // in the log Coulomb and Stribeck velocities.
  std::vector<Eigen::MatrixXd> F, dF_coulomb, dF_stribeck, cross;
  if (friction_) {
    for (int m = 0; m < n; ++m) {
      const int o = fo + FrictionKernel::kNumParams * m;
      Eigen::MatrixXd f(N, 4), dc(N, 4), dr(N, 4);
      Eigen::Vector4d dc_row, dr_row;
      for (Eigen::Index row = 0; row < N; ++row) {
        f.row(row) = friction_features(velocities_(row, m), lp(o + FrictionKernel::kCoulombVelocity),
                                       lp(o + FrictionKernel::kStribeckVelocity), &dc_row, &dr_row)
                         .transpose();
        dc.row(row) = dc_row.transpose();
        dr.row(row) = dr_row.transpose();
      }
      cross.push_back(phi_[static_cast<size_t>(m)] * f);  // energy features x 4
      F.push_back(std::move(f));
      dF_coulomb.push_back(std::move(dc));
      dF_stribeck.push_back(std::move(dr));
    }
  }

  // B = Phi^T D^-1 Phi (lower triangle) and b = Phi^T D^-1 y.
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(r, r);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(r);
  for (int j = 0; j < n; ++j) {
    const auto uj = static_cast<size_t>(j);
    const double inv = 1.0 / noise(j);
    B.topLeftCorner(rE, rE) += inv * gram_[uj];
    b.head(rE) += inv * phi_y_[uj];
    if (!friction_) continue;
    B.block(rE + 4 * j, 0, 4, rE) = inv * cross[uj].transpose();
    B.block(rE + 4 * j, rE + 4 * j, 4, 4) = inv * F[uj].transpose() * F[uj];
    b.segment(rE + 4 * j, 4) = inv * F[uj].transpose() * y_[uj];
  }
  // A = I + S^1/2 B S^1/2, factorised in place (lower triangle).
  Eigen::MatrixXd L = root_s.asDiagonal() * B * root_s.asDiagonal();
  L.diagonal().array() += 1.0;
  if (!L.allFinite()) {
    e.message = "the weight-space matrix has NaN or Inf entries (check the inputs and the hyperparameters)";
    return e;
  }
  const double norm1 = L.selfadjointView<Eigen::Lower>().toDenseMatrix().cwiseAbs().colwise().sum().maxCoeff();
  const lapack_int size = static_cast<lapack_int>(r);
  double rcond = 0.0;
  if (LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', size, L.data(), size) != 0 ||
      LAPACKE_dpocon(LAPACK_COL_MAJOR, 'L', size, L.data(), size, norm1, &rcond) != 0 ||
      !(rcond >= kMinReciprocalCondition)) {
    // A >= I, so only rounding fails it: where a noise variance is so small
    // against the kernel that rounding swamps the identity, kernel space's
    // jitter is what keeps the factorisation meaningful.
    e.status = NllEvaluation::Status::NotPositiveDefinite;
    e.message = "the weight-space matrix is too ill-conditioned (a noise variance far below the kernel's scale); "
                "evaluate in kernel space";
    return e;
  }
  Eigen::VectorXd m = root_s.cwiseProduct(b);
  cholesky_solve(L, m);
  const Eigen::VectorXd v = root_s.cwiseProduct(m);  // the posterior mean of the features' weights

  // Both terms of the quadratic form are sums of squares: nothing cancels at small noise.
  double quadratic = m.squaredNorm();
  double log_det = 2.0 * L.diagonal().array().log().sum();
  std::vector<Eigen::VectorXd> residual(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const auto uj = static_cast<size_t>(j);
    residual[uj] = y_[uj];
    residual[uj].noalias() -= phi_[uj].transpose() * v.head(rE);
    if (friction_) residual[uj].noalias() -= F[uj] * v.segment(rE + 4 * j, 4);
    quadratic += residual[uj].squaredNorm() / noise(j);
    log_det += static_cast<double>(N) * std::log(noise(j));
  }
  e.nll = gaussian_nll(quadratic, log_det, N * n);
  if (!std::isfinite(e.nll)) {
    e.message = "the marginal likelihood is not finite";
    return e;
  }
  if (alpha) {
    // alpha = D^-1 residual divides the residual's rounding by the noise, and
    // (K + D) multiplies it back by the kernel's largest eigenvalues: where a
    // joint's noise is small, (K + D) alpha misses y by far more than a
    // kernel-space factorisation's. Iterative refinement (the correction
    // solves (K + D) delta = y - (K + D) alpha by the same formulas, the
    // product costing O(N n r)) restores it.
    std::vector<Eigen::VectorXd> a(static_cast<size_t>(n));
    for (int j = 0; j < n; ++j) a[static_cast<size_t>(j)] = residual[static_cast<size_t>(j)] / noise(j);
    auto solve = [&](const std::vector<Eigen::VectorXd>& z, std::vector<Eigen::VectorXd>& out) {
      Eigen::VectorXd rhs = Eigen::VectorXd::Zero(r);
      for (int j = 0; j < n; ++j) {
        const auto uj = static_cast<size_t>(j);
        rhs.head(rE).noalias() += phi_[uj] * z[uj] / noise(j);
        if (friction_) rhs.segment(rE + 4 * j, 4).noalias() = F[uj].transpose() * z[uj] / noise(j);
      }
      Eigen::VectorXd mz = root_s.cwiseProduct(rhs);
      cholesky_solve(L, mz);
      const Eigen::VectorXd vz = root_s.cwiseProduct(mz);
      for (int j = 0; j < n; ++j) {
        const auto uj = static_cast<size_t>(j);
        out[uj] = z[uj];
        out[uj].noalias() -= phi_[uj].transpose() * vz.head(rE);
        if (friction_) out[uj].noalias() -= F[uj] * vz.segment(rE + 4 * j, 4);
        out[uj] /= noise(j);
      }
    };
    std::vector<Eigen::VectorXd> misfit(static_cast<size_t>(n)), correction(static_cast<size_t>(n));
    for (int step = 0; step < 2; ++step) {
      Eigen::VectorXd weights = Eigen::VectorXd::Zero(r);  // S Phi^T alpha
      for (int j = 0; j < n; ++j) {
        const auto uj = static_cast<size_t>(j);
        weights.head(rE).noalias() += phi_[uj] * a[uj];
        if (friction_) weights.segment(rE + 4 * j, 4).noalias() = F[uj].transpose() * a[uj];
      }
      weights = weights.cwiseProduct(root_s).cwiseProduct(root_s);
      for (int j = 0; j < n; ++j) {
        const auto uj = static_cast<size_t>(j);
        misfit[uj] = y_[uj] - noise(j) * a[uj];
        misfit[uj].noalias() -= phi_[uj].transpose() * weights.head(rE);
        if (friction_) misfit[uj].noalias() -= F[uj] * weights.segment(rE + 4 * j, 4);
      }
      solve(misfit, correction);
      for (int j = 0; j < n; ++j) a[static_cast<size_t>(j)] += correction[static_cast<size_t>(j)];
    }
    alpha->resize(N * n);
    for (Eigen::Index row = 0; row < N; ++row)
      for (int j = 0; j < n; ++j) (*alpha)(row * n + j) = a[static_cast<size_t>(j)](row);
  }
  e.status = NllEvaluation::Status::Ok;
  if (!with_gradient) return e;

  if (!cholesky_inverse_in_place(L)) {
    e.status = NllEvaluation::Status::InversionFailed;
    e.message = "cannot invert the weight-space matrix";
    return e;
  }
  const Eigen::MatrixXd A_inv = L.selfadjointView<Eigen::Lower>();
  // S^1/2 Phi^T (K + D)^-1 Phi S^1/2 = I - A^-1 and S^1/2 Phi^T alpha = m, so
  // d NLL / d log s_f = 1/2 (1 - (A^-1)_ff - m_f^2).
  const Eigen::VectorXd g = 0.5 * (1.0 - A_inv.diagonal().array() - m.array().square()).matrix();
  e.gradient = Eigen::VectorXd::Zero(P + n);
  std::vector<Monomials> kinetic_sum(static_cast<size_t>(n), Monomials{}), potential_sum(static_cast<size_t>(n), Monomials{});
  for (const Term& term : terms_)
    for (size_t pi = 0; pi < term.pairs.size(); ++pi)
      for (Eigen::Index p = 0; p < term.monomials.rows(); ++p) {
        const double gf = g(term.column + static_cast<Eigen::Index>(pi) * term.monomials.rows() + p);
        e.gradient(term.pair_params[pi]) += gf;
        for (size_t k = 0; k < term.joints.size(); ++k)
          kinetic_sum[static_cast<size_t>(term.joints[k])][static_cast<size_t>(term.monomials(p, static_cast<Eigen::Index>(k)))] += gf;
      }
  for (Eigen::Index p = 0; p < potential_monomials_.rows(); ++p)
    for (int m2 = 0; m2 < n; ++m2)
      potential_sum[static_cast<size_t>(m2)][static_cast<size_t>(potential_monomials_(p, m2))] += g(potential_column_ + p);
  for (int j = 0; j < n; ++j) {
    const auto uj = static_cast<size_t>(j);
    const bool rev = revolute_[uj];
    for (int p = 0; p < 2 * factor_size(rev); ++p)
      for (int k = 0; k < kinetic_monomials(rev); ++k)
        e.gradient(kinetic_offset[uj] + p) += kinetic_sum[uj][static_cast<size_t>(k)] * kinetic_jacobian[uj](k, p);
    for (int k = 0; k < factor_size(rev); ++k) e.gradient(potential_offset[uj] + k) += potential_sum[uj][static_cast<size_t>(k)];
    if (friction_)
      for (int k = 0; k < 4; ++k) e.gradient(fo + FrictionKernel::kNumParams * j + k) += g(rE + 4 * j + k);
  }

  // Noise of joint j: 1/2 (N - tr(S^1/2 A^-1 S^1/2 Phi_j^T Phi_j) / sigma_j^2 - |residual_j|^2 / sigma_j^2).
  const Eigen::MatrixXd A_scaled = root_s.asDiagonal() * A_inv * root_s.asDiagonal();
  for (int j = 0; j < n; ++j) {
    const auto uj = static_cast<size_t>(j);
    double trace = A_scaled.topLeftCorner(rE, rE).cwiseProduct(gram_[uj]).sum();
    if (friction_)
      trace += 2.0 * A_scaled.block(rE + 4 * j, 0, 4, rE).cwiseProduct(cross[uj].transpose()).sum() +
               A_scaled.block(rE + 4 * j, rE + 4 * j, 4, 4).cwiseProduct(F[uj].transpose() * F[uj]).sum();
    e.gradient(P + j) = 0.5 * (static_cast<double>(N) - (trace + residual[uj].squaredNorm()) / noise(j));
  }

  // Friction's velocities move its features psi_k = d phi_k / d theta:
  // d NLL / d theta = sum_k s_k (psi_k^T (K + D)^-1 phi_k - (psi_k^T alpha)(phi_k^T alpha)), where
  // (K + D)^-1 Phi S^1/2 = D^-1 Phi S^1/2 A^-1 and phi_k^T alpha = m_k / s_k^1/2 turn each term into a
  // product (no difference of large terms at small noise):
  // s_k^1/2 ((S^1/2 Phi^T D^-1 psi_k)^T A^-1 e_k - m_k psi_k^T alpha).
  for (int j = 0; j < n && friction_; ++j) {
    const auto uj = static_cast<size_t>(j);
    const double inv = 1.0 / noise(j);
    const int o = fo + FrictionKernel::kNumParams * j;
    for (const auto& [param, dF] : {std::pair{o + FrictionKernel::kCoulombVelocity, &dF_coulomb[uj]},
                                    std::pair{o + FrictionKernel::kStribeckVelocity, &dF_stribeck[uj]}}) {
      Eigen::MatrixXd U = Eigen::MatrixXd::Zero(r, 4);  // S^1/2 Phi^T D^-1 psi_k
      U.topRows(rE) = inv * (phi_[uj] * *dF);
      U.block(rE + 4 * j, 0, 4, 4) = inv * F[uj].transpose() * *dF;
      U = root_s.asDiagonal() * U;
      double sum = 0.0;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Index f = rE + 4 * j + k;
        const double psi_alpha = inv * dF->col(k).dot(residual[uj]);
        sum += root_s(f) * (U.col(k).dot(A_inv.col(f)) - m(f) * psi_alpha);
      }
      e.gradient(param) += sum;
    }
  }
  return e;
}

}  // namespace gipdyn
