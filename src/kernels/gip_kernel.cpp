#include "gipdyn/kernels/gip_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gipdyn/detail/factor_pair_product.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/kernels/composite_kernels.hpp"
#include "gipdyn/kernels/linear_kernel.hpp"
#include "gipdyn/parallel_tasks.hpp"

namespace gipdyn {
namespace {

constexpr Eigen::Index kChunk = 256;  // rows per block in the fused loops: keeps the blocks in L1/L2
#ifndef GIPDYN_PREDICT_CHUNK
#define GIPDYN_PREDICT_CHUNK 1024
#endif
constexpr Eigen::Index kPredictChunk = GIPDYN_PREDICT_CHUNK;  // rows per block of dot_rows

// From this many rows on, the Gram build and the fused gradient pass run in tasks on every core, as the
// factorisation's tiles do (gp/cholesky.hpp); below it, an evaluation is too short for threads to pay, and
// GP joints already share the cores. Each task writes only its own columns (or rows) and keeps its own share
// of the gradient, and the shares are added in task order: the tasks depend on the rows alone, so the result
// does not depend on how many threads run them.
constexpr Eigen::Index kParallelFromRows = 1536;
constexpr Eigen::Index kColumnsPerTask = 32;       // of the Gram build and the gradient pass's blocks
constexpr Eigen::Index kProductRowsPerTask = 512;  // of the acceleration weights' product

// The ranges of a matrix's `items` columns (or rows) that its tasks take, `per_task` at a time from
// kParallelFromRows rows on, all in one task below it.
std::vector<std::ptrdiff_t> task_ranges(Eigen::Index rows, Eigen::Index items, Eigen::Index per_task) {
  return equal_ranges(items, rows >= kParallelFromRows ? per_task : items);
}

// The sums over i < m of r_i, r_i u_i and r_i v_i, with r_i = a_i b_i c_i, in one
// pass (u, v may be null). Eight independent partial sums per quantity let the
// compiler vectorise the loop; the fused GIP gradient spends most of its time here.
struct FactorSums {
  double r = 0.0, ru = 0.0, rv = 0.0;   // over all m rows
  double r0 = 0.0, ru0 = 0.0, rv0 = 0.0;  // the first row's terms alone
};

FactorSums factor_sums(const double* a, const double* b, const double* c, const double* u, const double* v,
                       Eigen::Index m) {
  constexpr int kLanes = 8;
  using Lanes = Eigen::Array<double, kLanes, 1>;
  using In = Eigen::Map<const Lanes>;
  Lanes s = Lanes::Zero(), su = Lanes::Zero(), sv = Lanes::Zero();
  Eigen::Index i = 0;
  if (u && v) {
    for (; i + kLanes <= m; i += kLanes) {
      const Lanes r = In(a + i) * In(b + i) * In(c + i);
      s += r;
      su += r * In(u + i);
      sv += r * In(v + i);
    }
  } else if (u) {
    for (; i + kLanes <= m; i += kLanes) {
      const Lanes r = In(a + i) * In(b + i) * In(c + i);
      s += r;
      su += r * In(u + i);
    }
  } else {
    for (; i + kLanes <= m; i += kLanes) s += In(a + i) * In(b + i) * In(c + i);
  }
  // The lanes summed in the order of Eigen's AVX-512 reduction, written out:
  // GCC 12 warns falsely inside its own intrinsic for `Lanes::sum()` (bug 105593).
  auto lane_sum = [](const Lanes& x) { return ((x(0) + x(4)) + (x(1) + x(5))) + ((x(2) + x(6)) + (x(3) + x(7))); };
  FactorSums out;
  out.r = lane_sum(s);
  out.ru = lane_sum(su);
  out.rv = lane_sum(sv);
  for (; i < m; ++i) {
    const double r = a[i] * b[i] * c[i];
    out.r += r;
    if (u) out.ru += r * u[i];
    if (v) out.rv += r * v[i];
  }
  if (m > 0) {
    out.r0 = a[0] * b[0] * c[0];
    if (u) out.ru0 = out.r0 * u[0];
    if (v) out.rv0 = out.r0 * v[0];
  }
  return out;
}

std::vector<std::string> position_labels(const FeatureMap& fm, int b) {
  if (fm.joints().is_revolute(b)) return {"cos", "sin"};
  return {"q"};
}

std::vector<std::string> acceleration_labels(const FeatureMap& fm) {
  std::vector<std::string> labels;
  for (int c : fm.acceleration_group()) labels.push_back(fm.name(c));
  return labels;
}

std::string joint_prefix(const FeatureMap& fm, int b) {
  return "joint" + std::to_string(b + 1) + (fm.joints().is_revolute(b) ? ".cs" : ".p");
}

double mean_square(const Eigen::MatrixXd& Z, int column) {
  const double m = Z.rows() > 0 ? Z.col(column).squaredNorm() / static_cast<double>(Z.rows()) : 0.0;
  return m > 1e-12 ? m : 1.0;  // a constant-zero feature: its weight is irrelevant
}

}  // namespace

GipKernel::GipKernel(const FeatureMap& features, int friction_joint)
    : features_(features), friction_joint_(friction_joint) {
  const int n = features.num_joints();
  if (friction_joint >= n) throw Error("GipKernel: friction joint out of range");
  int offset = 0;
  for (int b = 0; b < n; ++b) {
    for (int s = 0; s < 2; ++s) {
      position_factors_.push_back({features.position_group(b), offset});
      offset += 1 + static_cast<int>(features.position_group(b).size());
    }
  }
  acceleration_ = {features.acceleration_group(), offset};
  offset += 1 + static_cast<int>(acceleration_.columns.size());
  acc_first_column_ = acceleration_.columns.front();
  if (friction_joint >= 0) {
    friction_offset_ = offset;
    offset += 2;
  }
  log_params_ = Eigen::VectorXd::Zero(offset);
  weights_ = Eigen::VectorXd::Ones(offset);
}

std::unique_ptr<Kernel> GipKernel::to_composite() const {
  std::vector<std::unique_ptr<Kernel>> factors;
  const int n = features_.num_joints();
  for (int b = 0; b < n; ++b)
    factors.push_back(make_mpk(features_.position_group(b), 2, joint_prefix(features_, b), position_labels(features_, b)));
  factors.push_back(std::make_unique<LinearKernel>(acceleration_.columns, true, "acc", acceleration_labels(features_)));
  std::unique_ptr<Kernel> k = std::make_unique<ProductKernel>(std::move(factors));
  if (has_friction()) {
    std::vector<std::unique_ptr<Kernel>> terms;
    terms.push_back(std::move(k));
    terms.push_back(std::make_unique<LinearKernel>(
        std::vector<int>{features_.friction_qd(friction_joint_), features_.friction_sign(friction_joint_)}, false,
        "friction", std::vector<std::string>{"viscous", "coulomb"}));
    k = std::make_unique<SumKernel>(std::move(terms));
  }
  k->set_log_params(log_params_);
  return k;
}

std::vector<std::string> GipKernel::param_names() const { return to_composite()->param_names(); }

void GipKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) {
  if (p.size() != log_params_.size())
    throw Error("GipKernel: expected " + std::to_string(log_params_.size()) + " parameters, got " +
                std::to_string(p.size()));
  log_params_ = p;
  weights_ = log_params_.array().exp();
}

void GipKernel::initialize(const Eigen::MatrixXd& Z, double target_variance) {
  const int num_factors = static_cast<int>(position_factors_.size()) + 1;
  const double per_factor = std::pow(std::max(target_variance, 1e-12), 1.0 / num_factors);
  auto init_factor = [&](const Factor& f, double bias_share) {
    log_params_(f.offset) = std::log(bias_share * per_factor);
    const double weight_share = (1.0 - bias_share) * per_factor / static_cast<double>(f.columns.size());
    for (size_t d = 0; d < f.columns.size(); ++d)
      log_params_(f.offset + 1 + static_cast<int>(d)) = std::log(weight_share / mean_square(Z, f.columns[d]));
  };
  for (size_t f = 0; f < position_factors_.size(); ++f) init_factor(position_factors_[f], f % 2 == 0 ? 0.25 : 0.75);
  init_factor(acceleration_, 0.5);
  if (has_friction()) {
    log_params_(friction_offset_) = std::log(0.1 * target_variance / mean_square(Z, features_.friction_qd(friction_joint_)));
    log_params_(friction_offset_ + 1) = std::log(0.1 * target_variance);
  }
  weights_ = log_params_.array().exp();
}

void GipKernel::acceleration_factor_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& A) const {
  const Eigen::Index na = static_cast<Eigen::Index>(acceleration_.columns.size());
  const Eigen::VectorXd sqrt_w = weights_.segment(acceleration_.offset + 1, na).cwiseSqrt();
  const Eigen::MatrixXd S = Z.middleCols(acc_first_column_, na) * sqrt_w.asDiagonal();
  A.resize(Z.rows(), Z.rows());
  A.triangularView<Eigen::Lower>().setConstant(weights_(acceleration_.offset));
  A.selfadjointView<Eigen::Lower>().rankUpdate(S);  // dsyrk
}

// The two factors of a joint's MPK_2 read the same columns: one pass for both.
template <class Query, class Column>
void GipKernel::apply_position(const Query& zq, const Eigen::MatrixXd& Z, Eigen::Index i0, Eigen::Index m,
                               Column col) const {
  const Eigen::VectorXd& w = weights_;
  for (size_t f = 0; f + 1 < position_factors_.size(); f += 2) {
    const Factor& f1 = position_factors_[f];
    const Factor& f2 = position_factors_[f + 1];
    const int c0 = f1.columns[0];
    const bool with_v = f1.columns.size() == 2;
    const int c1 = with_v ? f1.columns[1] : c0;
    const double p[3] = {w(f1.offset), w(f1.offset + 1) * zq(c0), with_v ? w(f1.offset + 2) * zq(c1) : 0.0};
    const double q[3] = {w(f2.offset), w(f2.offset + 1) * zq(c0), with_v ? w(f2.offset + 2) * zq(c1) : 0.0};
    detail::multiply_by_factor_pair(col.data(), Z.col(c0).data() + i0, with_v ? Z.col(c1).data() + i0 : nullptr, m,
                                    p, q);
  }
}

template <class Query, class Column>
void GipKernel::apply_position_and_friction(const Query& zq, const Eigen::MatrixXd& Z, Eigen::Index i0, Eigen::Index m,
                                            Column col) const {
  apply_position(zq, Z, i0, m, col);
  const Eigen::VectorXd& w = weights_;
  if (has_friction()) {
    const int cv = features_.friction_qd(friction_joint_), cc = features_.friction_sign(friction_joint_);
    col += (w(friction_offset_) * zq(cv)) * Z.col(cv).segment(i0, m).array() +
           (w(friction_offset_ + 1) * zq(cc)) * Z.col(cc).segment(i0, m).array();
  }
}

void GipKernel::gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& /*scratch*/) const {
  acceleration_factor_lower(Z, K);
  const Eigen::Index N = Z.rows();
  run_range_tasks(task_ranges(N, N, kColumnsPerTask), [&](int, Eigen::Index column_begin, Eigen::Index column_end) {
    for (Eigen::Index j = column_begin; j < column_end; ++j)
      apply_position_and_friction([&](int c) { return Z(j, c); }, Z, j, N - j, K.col(j).segment(j, N - j).array());
  });
}

void GipKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  const Eigen::Index na = static_cast<Eigen::Index>(acceleration_.columns.size());
  K.resize(Z1.rows(), Z2.rows());
  K.noalias() = (Z1.middleCols(acc_first_column_, na) * weights_.segment(acceleration_.offset + 1, na).asDiagonal()) *
                Z2.middleCols(acc_first_column_, na).transpose();
  K.array() += weights_(acceleration_.offset);
  for (Eigen::Index j = 0; j < Z2.rows(); ++j)
    apply_position_and_friction([&](int c) { return Z2(j, c); }, Z1, 0, Z1.rows(), K.col(j).array());
}

void GipKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  d.resize(Z.rows());
  for (Eigen::Index i = 0; i < Z.rows(); ++i) {
    const Eigen::RowVectorXd zi = Z.row(i);
    d(i) = value_at_itself(zi.data());
  }
}

double GipKernel::self(const double* z, int /*feature_dim*/, KernelScratch& /*scratch*/) const {
  return value_at_itself(z);
}

double GipKernel::value_at_itself(const double* z) const {
  auto factor = [&](const Factor& f) {
    double v = weights_(f.offset);
    for (size_t d = 0; d < f.columns.size(); ++d)
      v += weights_(f.offset + 1 + static_cast<int>(d)) * z[f.columns[d]] * z[f.columns[d]];
    return v;
  };
  double k = factor(acceleration_);
  for (const Factor& f : position_factors_) k *= factor(f);
  if (has_friction()) {
    const double v = z[features_.friction_qd(friction_joint_)], s = z[features_.friction_sign(friction_joint_)];
    k += weights_(friction_offset_) * v * v + weights_(friction_offset_ + 1) * s * s;
  }
  return k;
}

void GipKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                    KernelScratch& scratch) const {
  const Eigen::Index na = static_cast<Eigen::Index>(acceleration_.columns.size());
  Eigen::VectorXd& wz = scratch.w;
  if (wz.size() != na) wz.resize(na);
  wz = weights_.segment(acceleration_.offset + 1, na).cwiseProduct(Eigen::Map<const Eigen::VectorXd>(z + acc_first_column_, na));
  out.noalias() = Z.middleCols(acc_first_column_, na) * wz;  // dgemv, no allocation
  out.array() += weights_(acceleration_.offset);
  apply_position_and_friction([z](int c) { return z[c]; }, Z, 0, Z.rows(), out.array());
}

void GipKernel::dot_rows(const std::vector<const GipKernel*>& kernels,
                         const std::vector<const Eigen::VectorXd*>& alphas, const double* z, const Eigen::MatrixXd& Z,
                         Eigen::Ref<Eigen::VectorXd> out, KernelScratch& scratch) {
  const Eigen::Index J = static_cast<Eigen::Index>(kernels.size()), N = Z.rows();
  const GipKernel& first = *kernels.front();
  const Eigen::Index na = static_cast<Eigen::Index>(first.acceleration_.columns.size());
  const int a0 = first.acc_first_column_;
  Eigen::MatrixXd& W = scratch.a;
  Eigen::MatrixXd& block = scratch.b;
  Eigen::VectorXd& constants = scratch.v;  // not w, which row() keeps at another size
  if (W.rows() != na || W.cols() != J) W.resize(na, J);
  if (constants.size() != J) constants.resize(J);
  if (block.rows() != kPredictChunk || block.cols() != J) block.resize(kPredictChunk, J);
  for (Eigen::Index j = 0; j < J; ++j) {
    const GipKernel& k = *kernels[static_cast<size_t>(j)];
    W.col(j) = k.weights_.segment(k.acceleration_.offset + 1, na).cwiseProduct(Eigen::Map<const Eigen::VectorXd>(z + a0, na));
    constants(j) = k.weights_(k.acceleration_.offset);
  }
  out.setZero();
  for (Eigen::Index i0 = 0; i0 < N; i0 += kPredictChunk) {
    const Eigen::Index m = std::min(kPredictChunk, N - i0);
    // Every joint's acceleration factor: constant + Z_acc W, in one pass over the columns.
    detail::set_affine_combinations(block.data(), block.outerStride(), static_cast<int>(J), m, constants.data(),
                                    Z.col(a0).data() + i0, Z.outerStride(), W.data(), W.outerStride(),
                                    static_cast<int>(na));
    for (Eigen::Index j = 0; j < J; ++j) {
      const GipKernel& k = *kernels[static_cast<size_t>(j)];
      k.apply_position_and_friction([z](int c) { return z[c]; }, Z, i0, m, block.col(j).head(m).array());
      out(j) += block.col(j).head(m).dot(alphas[static_cast<size_t>(j)]->segment(i0, m));
    }
  }
}

void GipKernel::affine_coefficients(const std::vector<const GipKernel*>& kernels,
                                    const std::vector<const Eigen::VectorXd*>& alphas, const double* z,
                                    const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::MatrixXd> coeff,
                                    KernelScratch& scratch) {
  const Eigen::Index J = static_cast<Eigen::Index>(kernels.size()), N = Z.rows();
  const GipKernel& first = *kernels.front();
  const Eigen::Index na = static_cast<Eigen::Index>(first.acceleration_.columns.size());
  const int a0 = first.acc_first_column_;
  Eigen::MatrixXd& U = scratch.b;  // alpha_i P_i(z), per joint
  if (U.rows() != kPredictChunk || U.cols() != J) U.resize(kPredictChunk, J);
  coeff.setZero();
  for (Eigen::Index i0 = 0; i0 < N; i0 += kPredictChunk) {
    const Eigen::Index m = std::min(kPredictChunk, N - i0);
    for (Eigen::Index j = 0; j < J; ++j) {
      const GipKernel& k = *kernels[static_cast<size_t>(j)];
      auto u = U.col(j).head(m).array();
      u = alphas[static_cast<size_t>(j)]->segment(i0, m).array();
      k.apply_position([z](int c) { return z[c]; }, Z, i0, m, u);
      coeff(0, j) += u.sum();
    }
    detail::add_column_dot_products(coeff.data() + 1, coeff.outerStride(), static_cast<int>(na), static_cast<int>(J), m,
                                    Z.col(a0).data() + i0, Z.outerStride(), U.data(), U.outerStride());  // Z_acc' U
  }
  for (Eigen::Index j = 0; j < J; ++j) {
    const GipKernel& k = *kernels[static_cast<size_t>(j)];
    const Eigen::VectorXd& w = k.weights_;
    coeff(0, j) *= w(k.acceleration_.offset);
    coeff.col(j).segment(1, na).array() *= w.segment(k.acceleration_.offset + 1, na).array();
    if (k.has_friction()) {
      const Eigen::VectorXd& alpha = *alphas[static_cast<size_t>(j)];
      coeff(na + 1, j) = w(k.friction_offset_) * Z.col(k.features_.friction_qd(k.friction_joint_)).dot(alpha);
      coeff(na + 2, j) = w(k.friction_offset_ + 1) * Z.col(k.features_.friction_sign(k.friction_joint_)).dot(alpha);
    }
  }
}

double GipKernel::affine_value(const Eigen::Ref<const Eigen::VectorXd>& coeff, const double* z) const {
  const Eigen::Index na = static_cast<Eigen::Index>(acceleration_.columns.size());
  double f = coeff(0) + coeff.segment(1, na).dot(Eigen::Map<const Eigen::VectorXd>(z + acc_first_column_, na));
  if (has_friction())
    f += coeff(na + 1) * z[features_.friction_qd(friction_joint_)] +
         coeff(na + 2) * z[features_.friction_sign(friction_joint_)];
  return f;
}

void GipKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                Eigen::MatrixXd& dK) const {
  to_composite()->gradient_matrix(Z1, Z2, p, dK);
}

// Fused gradient contraction: grad(p) += sum_ij W_ij dK_ij/dlog(theta_p).
// For a factor f of the product, dK/dtheta = R_f o dF_f with R_f the product of
// the other factors; R_f comes from prefix and suffix products of the factor values,
// computed block by block (over the lower triangle when K is symmetric, W and K
// being symmetric then), so the only large buffer is the acceleration factor,
// which is overwritten by W o R_acc; its weight gradients are then one product:
// diag(Za1^T (W o R_acc) Za2), by blocks of rows on every core from
// kParallelFromRows rows on.
template <class WeightColumn>
void GipKernel::fused_contract(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, bool symmetric,
                               WeightColumn&& weight_column, Eigen::Ref<Eigen::VectorXd> grad,
                               KernelScratch& scratch) const {
  const Eigen::Index N1 = Z1.rows(), N2 = Z2.rows();
  const int P = static_cast<int>(position_factors_.size());
  const Eigen::Index na = static_cast<Eigen::Index>(acceleration_.columns.size());
  const Eigen::VectorXd& w = weights_;
  Eigen::MatrixXd& A = scratch.a;
  if (symmetric) {
    acceleration_factor_lower(Z1, A);
  } else {
    A.resize(N1, N2);
    A.noalias() = (Z1.middleCols(acc_first_column_, na) * weights_.segment(acceleration_.offset + 1, na).asDiagonal()) *
                  Z2.middleCols(acc_first_column_, na).transpose();
    A.array() += weights_(acceleration_.offset);
  }

  // Per block: F (P + 1 columns), prefix products with a leading column of ones
  // (P + 2), suffix products with a trailing one (P + 2), wraw. R_f = Pre(f) o Suf(f + 2).
  // Each task of columns has its own block and its own share of the gradient;
  // the columns of A it overwrites are its own.
  const std::vector<std::ptrdiff_t> column_ranges = task_ranges(N1, N2, kColumnsPerTask);
  std::vector<Eigen::VectorXd> shares(column_ranges.size() - 1);
  run_range_tasks(column_ranges, [&](int task, Eigen::Index column_begin, Eigen::Index column_end) {
    Eigen::MatrixXd B(kChunk, 3 * (P + 1) + 3);
    auto F = [&](int f) { return B.col(f); };
    auto Pre = [&](int f) { return B.col(P + 1 + f); };
    auto Suf = [&](int f) { return B.col(2 * (P + 1) + 1 + f); };
    auto wraw = B.col(3 * (P + 1) + 2);
    Pre(0).setOnes();
    Suf(P + 1).setOnes();
    Eigen::VectorXd g = Eigen::VectorXd::Zero(num_params());

    for (Eigen::Index j = column_begin; j < column_end; ++j) {
      for (Eigen::Index i0 = symmetric ? j : 0; i0 < N1; i0 += kChunk) {
        const Eigen::Index m = std::min(kChunk, N1 - i0);
        const bool has_diag = symmetric && i0 == j;
        // Over the full matrix: a symmetric one's lower-triangle block counts twice, less its diagonal.
        auto wsum = [&](double sum, double first) { return symmetric ? 2.0 * sum - (has_diag ? first : 0.0) : sum; };
        weight_column(j, i0, m, wraw.head(m));
        for (int f = 0; f < P; ++f) {
          const Factor& fac = position_factors_[static_cast<size_t>(f)];
          const int c0 = fac.columns[0];
          auto Ff = F(f).head(m).array();
          Ff = w(fac.offset) + (w(fac.offset + 1) * Z2(j, c0)) * Z1.col(c0).segment(i0, m).array();
          if (fac.columns.size() == 2) {
            const int c1 = fac.columns[1];
            Ff += (w(fac.offset + 2) * Z2(j, c1)) * Z1.col(c1).segment(i0, m).array();
          }
        }
        F(P).head(m) = A.col(j).segment(i0, m);
        for (int f = 0; f < P; ++f) Pre(f + 1).head(m).array() = Pre(f).head(m).array() * F(f).head(m).array();
        for (int f = P; f >= 1; --f) Suf(f).head(m).array() = F(f).head(m).array() * Suf(f + 1).head(m).array();

        for (int f = 0; f < P; ++f) {
          const Factor& fac = position_factors_[static_cast<size_t>(f)];
          const double* u = Z1.col(fac.columns[0]).data() + i0;
          const double* v = fac.columns.size() == 2 ? Z1.col(fac.columns[1]).data() + i0 : nullptr;
          const FactorSums t = factor_sums(wraw.data(), Pre(f).data(), Suf(f + 1).data(), u, v, m);
          g(fac.offset) += w(fac.offset) * wsum(t.r, t.r0);
          g(fac.offset + 1) += w(fac.offset + 1) * Z2(j, fac.columns[0]) * wsum(t.ru, t.ru0);
          if (v) g(fac.offset + 2) += w(fac.offset + 2) * Z2(j, fac.columns[1]) * wsum(t.rv, t.rv0);
        }
        auto r_acc = A.col(j).segment(i0, m).array();
        r_acc = wraw.head(m).array() * Pre(P).head(m).array();  // W o R_acc
        g(acceleration_.offset) += w(acceleration_.offset) * wsum(r_acc.sum(), r_acc(0));
        if (has_friction()) {
          const int cv = features_.friction_qd(friction_joint_), cc = features_.friction_sign(friction_joint_);
          const FactorSums t = factor_sums(wraw.data(), Pre(0).data(), Suf(P + 1).data(), Z1.col(cv).data() + i0,
                                           Z1.col(cc).data() + i0, m);
          g(friction_offset_) += w(friction_offset_) * Z2(j, cv) * wsum(t.ru, t.ru0);
          g(friction_offset_ + 1) += w(friction_offset_ + 1) * Z2(j, cc) * wsum(t.rv, t.rv0);
        }
      }
    }
    shares[static_cast<size_t>(task)] = std::move(g);
  });
  Eigen::VectorXd g = Eigen::VectorXd::Zero(num_params());
  for (const Eigen::VectorXd& share : shares) g += share;
  // M = A Za2, A symmetric (its lower triangle stored) or not, one block of
  // rows per task: each block's sum runs the same whatever the threads.
  const auto Za1 = Z1.middleCols(acc_first_column_, na);
  const auto Za2 = Z2.middleCols(acc_first_column_, na);
  Eigen::MatrixXd& M = scratch.d;
  M.resize(N1, na);
  run_range_tasks(task_ranges(N1, N1, kProductRowsPerTask), [&](int, Eigen::Index r0, Eigen::Index r1) {
    const Eigen::Index h = r1 - r0;
    auto Mt = M.middleRows(r0, h);
    if (!symmetric) {
      Mt.noalias() = A.middleRows(r0, h) * Za2;
      return;
    }
    Mt.noalias() = A.block(r0, r0, h, h).selfadjointView<Eigen::Lower>() * Za2.middleRows(r0, h);  // dsymm
    if (r0 > 0) Mt.noalias() += A.block(r0, 0, h, r0) * Za2.topRows(r0);
    const Eigen::Index below = N1 - r0 - h;
    if (below > 0) Mt.noalias() += A.block(r0 + h, r0, below, h).transpose() * Za2.bottomRows(below);
  });
  for (Eigen::Index d = 0; d < na; ++d)
    g(acceleration_.offset + 1 + d) += w(acceleration_.offset + 1 + d) * Za1.col(d).dot(M.col(d));
  grad += g;
}

void GipKernel::contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                             Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  fused_contract(
      Z, Z, true,
      [&](Eigen::Index j, Eigen::Index i0, Eigen::Index m, auto out) {
        out = alpha(j) * alpha.segment(i0, m) - Kinv_lower.col(j).segment(i0, m);
      },
      grad, scratch);
}

void GipKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                         KernelScratch& scratch) const {
  fused_contract(
      Z, Z, true, [&](Eigen::Index j, Eigen::Index i0, Eigen::Index m, auto out) { out = W.col(j).segment(i0, m); },
      grad, scratch);
}

void GipKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                               Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  fused_contract(
      Z1, Z2, false, [&](Eigen::Index j, Eigen::Index i0, Eigen::Index m, auto out) { out = W.col(j).segment(i0, m); },
      grad, scratch);
}

}  // namespace gipdyn
