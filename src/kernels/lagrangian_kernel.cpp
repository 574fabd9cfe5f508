#include "gipdyn/kernels/lagrangian_kernel.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/kernels/friction_kernel.hpp"
#include "gipdyn/parallel_tasks.hpp"

// Notation (docs/method.md section 11). For one pair of states x1 = (q1, qd1,
// qdd1), x2 = (q2, qd2, qdd2) and a position kernel p(q1, q2) = prod_m p_m:
//   P = p, g_i = dp/dq1_i, g'_j = dp/dq2_j, H_ij = d2p/dq1_i dq2_j.
// Each joint contributes a jet (p_m, dp_m/dq1_m, dp_m/dq2_m, d2p_m/dq1_m dq2_m);
// every position quantity is a product of one jet entry per joint.
//
// With nu the symmetric velocity weights (lambda_aa, lambda_ab / 2) and
//   S(x, y)_ij = 2 delta_ij (nu (x o y))_i + 2 nu_ij y_i x_j,
// the kinetic energy's torque covariance is
//   K_ij = S(qdd1, qdd2) P + S(qdd1, qd2) qd2.g' + S(qd1, qdd2) qd1.g + S(qd1, qd2) qd1' H qd2
//        - 2 qd2_i (nu (qdd1 o qd2))_i g'_j - 2 qd2_i (nu (qd1 o qd2))_i (H' qd1)_j
//        - 2 qd1_j (nu (qdd2 o qd1))_j g_i  - 2 qd1_j (nu (qd1 o qd2))_j (H qd2)_i
//        + (qd1 o qd2)' nu (qd1 o qd2) H_ij
// and the potential energy's is H_ij of its own position kernel.

namespace gipdyn {

using Jet = std::array<double, 4>;

namespace {

Jet jet_product(const Jet& a, const Jet& b) {
  return {a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + a[0] * b[2],
          a[3] * b[0] + a[1] * b[2] + a[2] * b[1] + a[0] * b[3]};
}

// One joint's positions in a pair of states and, for a revolute joint, their
// cosines and sines: computed once per pair, read by every factor's jets.
struct AnglePair {
  double q1 = 0.0, q2 = 0.0, c1 = 0.0, s1 = 0.0, c2 = 0.0, s2 = 0.0;
};

AnglePair angle_pair(bool revolute, double q1, double q2) {
  if (!revolute) return {q1, q2, 0.0, 0.0, 0.0, 0.0};
  return {q1, q2, std::cos(q1), std::sin(q1), std::cos(q2), std::sin(q2)};
}

// One linear factor s0 + sum_k l_k z_k(q1) z_k(q2) and its derivatives.
// params: (s0, l_cos, l_sin) for a revolute joint, (s0, l) for a prismatic one.
Jet factor_jet(bool revolute, const double* params, const AnglePair& a) {
  if (!revolute) {
    const double l = params[1];
    return {params[0] + l * a.q1 * a.q2, l * a.q2, l * a.q1, l};
  }
  const double c1 = a.c1, s1 = a.s1, c2 = a.c2, s2 = a.s2;
  const double lc = params[1], ls = params[2];
  return {params[0] + lc * c1 * c2 + ls * s1 * s2, -lc * s1 * c2 + ls * c1 * s2, -lc * c1 * s2 + ls * s1 * c2,
          lc * s1 * s2 + ls * c1 * c2};
}

// d factor_jet / d log(param k).
Jet factor_jet_derivative(bool revolute, const double* params, int k, const AnglePair& a) {
  if (k == 0) return {params[0], 0.0, 0.0, 0.0};
  if (!revolute) {
    const double l = params[1];
    return {l * a.q1 * a.q2, l * a.q2, l * a.q1, l};
  }
  const double c1 = a.c1, s1 = a.s1, c2 = a.c2, s2 = a.s2;
  if (k == 1) {
    const double lc = params[1];
    return {lc * c1 * c2, -lc * s1 * c2, -lc * c1 * s2, lc * s1 * s2};
  }
  const double ls = params[2];
  return {ls * s1 * s2, ls * c1 * s2, ls * s1 * c2, ls * c1 * c2};
}

// Coefficients of a linear function of the position quantities:
// value = cP P + cg.g + cgp.g' + <cH, H>.
struct PositionCoefficients {
  double cP = 0.0;
  Eigen::VectorXd cg, cgp;
  Eigen::MatrixXd cH;
  void reset(int n) {
    cP = 0.0;
    cg.setZero(n);
    cgp.setZero(n);
    cH.setZero(n, n);
  }
};

// prefix[m] = product of the jets' values before joint m, suffix[m] = from joint m on.
void value_products(const std::vector<Jet>& jets, std::vector<double>& prefix, std::vector<double>& suffix) {
  const size_t n = jets.size();
  prefix.resize(n + 1);  // sized once per scratch; every entry is written below
  suffix.resize(n + 1);
  prefix[0] = suffix[n] = 1.0;
  for (size_t m = 0; m < n; ++m) prefix[m + 1] = prefix[m] * jets[m][0];
  for (size_t m = n; m-- > 0;) suffix[m] = suffix[m + 1] * jets[m][0];
}

// Scratch of position_sensitivities: the adjoints after each joint.
struct SensitivityScratch {
  std::vector<double> after_done, after_start;
  Eigen::MatrixXd after_pending1, after_pending2;  // column k: after joint k, rows j > k
  Eigen::VectorXd pending1, pending2;
  explicit SensitivityScratch(int n)
      : after_done(static_cast<size_t>(n)), after_start(static_cast<size_t>(n)), after_pending1(n, n),
        after_pending2(n, n), pending1(n), pending2(n) {}
};

// The partial derivatives d[m] = d value / d jets[m] (m >= first) of the
// linear function of the position quantities of the product of `jets`,
//   value = cP P + cg.g + cg'.g' + <cH, H>,
// which is linear in each jet. The value is a sum over assignments of one jet
// entry per joint (entry 0 for all joints but at most two), so it is computed
// by a sweep over the joints whose state after joint k is: `done`, the terms
// already complete; `start`, the product of entries 0 (no term begun); and
// for each later joint j, `pending1[j]` (an earlier joint i took entry 1 and
// j must take entry 2: cH(i, j)) and `pending2[j]` (i took entry 2: cH(j, i)).
// A joint's step is linear in its jet, so its derivative is the state before
// the step contracted with the adjoint after it: one backward sweep for the
// adjoints and one forward sweep for the states give every joint's
// derivative in O(n^2), where differentiating joint by joint takes O(n^3).
// Jets before `first`: unit jets, whose derivatives are not wanted.
void position_sensitivities(const std::vector<Jet>& jets, const PositionCoefficients& c, int first,
                            SensitivityScratch& s, std::vector<Jet>& d) {
  const int n = static_cast<int>(jets.size());
  if (first >= n) return;
  // Backward: the adjoint after joint n - 1 reads `done` alone.
  double a_done = 1.0, a_start = 0.0;
  for (int k = n - 1; k >= first; --k) {
    const size_t uk = static_cast<size_t>(k);
    s.after_done[uk] = a_done;
    s.after_start[uk] = a_start;
    const Jet& J = jets[uk];
    // The adjoint before joint k is the one after joint k - 1.
    double pending_share = 0.0;
    for (int j = k + 1; j < n; ++j)
      pending_share += s.after_pending1(j, k) * c.cH(k, j) * J[1] + s.after_pending2(j, k) * c.cH(j, k) * J[2];
    const double before_start = a_start * J[0] + a_done * (c.cg(k) * J[1] + c.cgp(k) * J[2] + c.cH(k, k) * J[3]) +
                                pending_share;
    if (k > first) {
      for (int j = k + 1; j < n; ++j) {
        s.after_pending1(j, k - 1) = s.after_pending1(j, k) * J[0];
        s.after_pending2(j, k - 1) = s.after_pending2(j, k) * J[0];
      }
      s.after_pending1(k, k - 1) = a_done * J[2];
      s.after_pending2(k, k - 1) = a_done * J[1];
    }
    a_done *= J[0];
    a_start = before_start;
  }
  // Forward: the state before joint `first` (unit jets before it).
  double done = c.cP, start = 1.0;
  s.pending1.tail(n - first).setZero();
  s.pending2.tail(n - first).setZero();
  for (int k = first; k < n; ++k) {
    const size_t uk = static_cast<size_t>(k);
    const double ad = s.after_done[uk];
    double d0 = ad * done + s.after_start[uk] * start, d1 = 0.0, d2 = 0.0;
    for (int j = k + 1; j < n; ++j) {
      d0 += s.after_pending1(j, k) * s.pending1(j) + s.after_pending2(j, k) * s.pending2(j);
      d1 += s.after_pending1(j, k) * c.cH(k, j);
      d2 += s.after_pending2(j, k) * c.cH(j, k);
    }
    Jet& dk = d[uk];
    dk[0] = d0;
    dk[1] = ad * (start * c.cg(k) + s.pending2(k)) + start * d1;
    dk[2] = ad * (start * c.cgp(k) + s.pending1(k)) + start * d2;
    dk[3] = ad * start * c.cH(k, k);
    const Jet& J = jets[uk];
    done = done * J[0] + start * (c.cg(k) * J[1] + c.cgp(k) * J[2] + c.cH(k, k) * J[3]) + s.pending1(k) * J[2] +
           s.pending2(k) * J[1];
    for (int j = k + 1; j < n; ++j) {
      s.pending1(j) = s.pending1(j) * J[0] + start * c.cH(k, j) * J[1];
      s.pending2(j) = s.pending2(j) * J[0] + start * c.cH(j, k) * J[2];
    }
    start *= J[0];
  }
}

// The position quantities themselves (P, g, g', H) of the product of `jets`.
void position_quantities(const std::vector<Jet>& jets, double& P, Eigen::VectorXd& g, Eigen::VectorXd& gp,
                         Eigen::MatrixXd& H, std::vector<double>& prefix, std::vector<double>& suffix) {
  const int n = static_cast<int>(jets.size());
  value_products(jets, prefix, suffix);
  P = prefix[static_cast<size_t>(n)];
  for (int i = 0; i < n; ++i) {
    const Jet& ji = jets[static_cast<size_t>(i)];
    const double all_but_i = prefix[static_cast<size_t>(i)] * suffix[static_cast<size_t>(i) + 1];
    g(i) = ji[1] * all_but_i;
    gp(i) = ji[2] * all_but_i;
    H(i, i) = ji[3] * all_but_i;
    double between = 1.0;
    for (int j = i + 1; j < n; ++j) {
      const Jet& jj = jets[static_cast<size_t>(j)];
      const double all_but_ij = prefix[static_cast<size_t>(i)] * between * suffix[static_cast<size_t>(j) + 1];
      H(i, j) = ji[1] * jj[2] * all_but_ij;
      H(j, i) = jj[1] * ji[2] * all_but_ij;
      between *= jj[0];
    }
  }
}

// The position quantities (P, g, g', H) of a product of jets over joints
// m + 1.. made those of the product with jet J of joint m in front: in O(n^2)
// scalings, where position_quantities recomputes them with prefix and
// suffix products. Entries before m stay zero.
void prepend_factor(const Jet& J, int m, double& P, Eigen::VectorXd& g, Eigen::VectorXd& gp, Eigen::MatrixXd& H) {
  const int n = static_cast<int>(g.size());
  for (int j = m + 1; j < n; ++j) {
    for (int i = m + 1; i < n; ++i) H(i, j) *= J[0];
    H(m, j) = J[1] * gp(j);
    H(j, m) = J[2] * g(j);
    g(j) *= J[0];
    gp(j) *= J[0];
  }
  H(m, m) = J[3] * P;
  g(m) = J[1] * P;
  gp(m) = J[2] * P;
  P *= J[0];
}

// S(x, y) of the notation above, added to K.
void add_symmetric_term(const Eigen::MatrixXd& nu, const Eigen::Ref<const Eigen::VectorXd>& x,
                        const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::MatrixXd> K) {
  // Loops, not expressions: Eigen would evaluate the outer product into a
  // heap temporary, and single queries must not allocate.
  const Eigen::Index n = nu.rows();
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = 0; i < n; ++i) K(i, j) += 2.0 * nu(i, j) * y(i) * x(j);
  for (Eigen::Index i = 0; i < n; ++i) {
    double d = 0.0;
    for (Eigen::Index j = 0; j < n; ++j) d += nu(i, j) * x(j) * y(j);
    K(i, i) += 2.0 * d;
  }
}

// G = d <W, S(x, y)> / d nu_ab, the entries of nu taken as independent.
// Loops on references, not expressions: W is a block of the caller's matrix
// and x, y map a state, so Eigen would copy them into heap temporaries on
// every pair of the gradient's O(N^2) loop.
void symmetric_term_gradient(const Eigen::Ref<const Eigen::MatrixXd>& W, const Eigen::Ref<const Eigen::VectorXd>& x,
                             const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::MatrixXd& G) {
  const Eigen::Index n = W.rows();
  for (Eigen::Index b = 0; b < n; ++b) {
    const double xy = 2.0 * x(b) * y(b), sx = 2.0 * x(b);
    for (Eigen::Index a = 0; a < n; ++a) G(a, b) = W(a, a) * xy + W(a, b) * y(a) * sx;
  }
}

// The ranges of rows of a lower triangle that its tasks take (run_range_tasks):
// they depend on the rows only, and row r costs about r, so they balance the
// work, not the rows. Callers that accumulate keep one sum per range.
constexpr int kMaxRanges = 8;
std::vector<std::ptrdiff_t> lower_triangle_ranges(Eigen::Index rows) {
  const int ranges = static_cast<int>(std::clamp<Eigen::Index>(rows / 16, 1, kMaxRanges));
  std::vector<std::ptrdiff_t> bounds(static_cast<size_t>(ranges) + 1, rows);
  bounds[0] = 0;
  for (int c = 1; c < ranges; ++c)
    bounds[static_cast<size_t>(c)] =
        static_cast<Eigen::Index>(static_cast<double>(rows) * std::sqrt(static_cast<double>(c) / ranges));
  return bounds;
}

}  // namespace

// Scratch for one pair of states.
struct LagrangianKernel::PairTerms {
  // Whether the states carry their joints' cosines and sines after qdd
  // (with_trigonometry), so that a pair reads them instead of computing them.
  bool trigonometry_appended = false;
  std::vector<AnglePair> angles;
  std::vector<Jet> kinetic, potential;
  double P = 0.0, PV = 0.0;
  Eigen::VectorXd g, gp, gV, gpV;
  // Velocity products of the notation above: e = qd1 o qd2, v5 = qdd1 o qd2,
  // v7 = qdd2 o qd1 (per pair); per term b = nu e, a5 = nu v5, c7 = nu v7,
  // h6 = H' qd1, h8 = H qd2, P1 = qd1.g, P1p = qd2.g', Q = qd1' H qd2.
  Eigen::VectorXd e, v5, v7, b, a5, c7, h6, h8;
  double P1 = 0.0, P1p = 0.0, Q = 0.0;
  Eigen::MatrixXd H, HV;
  // The velocity weights times each term's P, P1p, P1 and Q: the four S terms
  // of all kinetic terms are linear in nu, so they add up to four S terms.
  Eigen::MatrixXd nuP, nuP1p, nuP1, nuQ;
  std::vector<double> prefix, suffix;
  // Scratch of add_pair_gradient: d<W, S(x, y)>/d nu for the four S terms,
  // and W or W' times a term's vectors.
  Eigen::MatrixXd MP, MP1p, MP1, MQ;
  Eigen::VectorXd Wgp, Wh6, Wtg, Wth8, u, w;
  PositionCoefficients kin, pot;
  // position_sensitivities' scratch and its derivatives, one jet per joint.
  SensitivityScratch sensitivity;
  std::vector<Jet> jet_derivatives;
  // Per joint: the sum over the kinetic terms of their sensitivities to its jet.
  std::vector<Jet> kinetic_sensitivity;
  explicit PairTerms(int n)
      : angles(static_cast<size_t>(n)), kinetic(static_cast<size_t>(n)), potential(static_cast<size_t>(n)),
        g(n), gp(n), gV(n), gpV(n), e(n), v5(n), v7(n), b(n), a5(n), c7(n),
        h6(n), h8(n), H(n, n), HV(n, n), nuP(n, n), nuP1p(n, n), nuP1(n, n), nuQ(n, n),
        prefix(static_cast<size_t>(n) + 1), suffix(static_cast<size_t>(n) + 1), MP(n, n), MP1p(n, n), MP1(n, n),
        MQ(n, n), Wgp(n), Wh6(n), Wtg(n), Wth8(n), u(n), w(n), sensitivity(n),
        jet_derivatives(static_cast<size_t>(n)), kinetic_sensitivity(static_cast<size_t>(n)) {
    kin.reset(n);
    pot.reset(n);
  }
};

LagrangianKernel::LagrangianKernel(JointTypes joints, bool friction, bool serial_chain)
    : joints_(std::move(joints)), n_(joints_.size()), serial_chain_(serial_chain) {
  int offset = num_velocity_weights();
  for (int m = 0; m < n_; ++m) {
    kinetic_offset_.push_back(offset);
    offset += 2 * factor_size(m);
  }
  potential_offset_ = offset;
  for (int m = 0; m < n_; ++m) {
    potential_joint_.push_back(offset);
    offset += factor_size(m);
  }
  if (friction) {
    friction_offset_ = offset;
    offset += FrictionKernel::kNumParams * n_;
  }
  log_params_ = Eigen::VectorXd::Zero(offset);
  set_log_params(log_params_);
}

std::vector<std::string> LagrangianKernel::param_names() const {
  std::vector<std::string> names;
  for (int a = 0; a < n_; ++a)
    for (int b = a; b < n_; ++b)
      names.push_back("kinetic.velocity.w" + std::to_string(a + 1) + "_" + std::to_string(b + 1));
  auto factor_names = [&](int m, const std::string& prefix) {
    names.push_back(prefix + ".bias");
    if (joints_.is_revolute(m)) {
      names.push_back(prefix + ".l_cos");
      names.push_back(prefix + ".l_sin");
    } else {
      names.push_back(prefix + ".l_q");
    }
  };
  for (int m = 0; m < n_; ++m)
    for (int f = 1; f <= 2; ++f)
      factor_names(m, "kinetic.joint" + std::to_string(m + 1) + ".factor" + std::to_string(f));
  for (int m = 0; m < n_; ++m) factor_names(m, "potential.joint" + std::to_string(m + 1));
  if (has_friction())
    for (int m = 0; m < n_; ++m)
      for (const auto& name : FrictionKernel(2 * n_ + m, "friction.joint" + std::to_string(m + 1)).param_names())
        names.push_back(name);
  return names;
}

void LagrangianKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& log_params) {
  if (log_params.size() != log_params_.size())
    throw Error("LagrangianKernel: " + std::to_string(log_params.size()) + " log-parameters given, " +
                std::to_string(log_params_.size()) + " expected for joints " + joints_.str());
  if (!log_params.allFinite()) throw Error("LagrangianKernel: a log-parameter is not finite");
  log_params_ = log_params;
  // Entry by entry: Eigen's vectorised exp can differ in the last bit from the
  // scalar one it uses for a vector's tail, so a parameter's value would depend
  // on how many others the vector holds (with friction or without).
  params_ = log_params_.unaryExpr([](double v) { return std::exp(v); });
  nu_.resize(n_, n_);
  int k = 0;
  for (int a = 0; a < n_; ++a)
    for (int b = a; b < n_; ++b, ++k) {
      nu_(a, b) = nu_(b, a) = a == b ? params_(k) : 0.5 * params_(k);
    }
}

int LagrangianKernel::first_kinetic_joint(int term) const { return serial_chain_ ? term + 1 : 0; }

void LagrangianKernel::position_jets(const double* x1, const double* x2, PairTerms& t) const {
  const int n = n_;
  for (int m = 0; m < n; ++m) {
    const bool rev = joints_.is_revolute(m);
    const double* kp = params_.data() + kinetic_offset_[static_cast<size_t>(m)];
    AnglePair& a = t.angles[static_cast<size_t>(m)];
    if (rev && t.trigonometry_appended)
      a = {x1[m], x2[m], x1[3 * n + m], x1[4 * n + m], x2[3 * n + m], x2[4 * n + m]};
    else
      a = angle_pair(rev, x1[m], x2[m]);
    t.kinetic[static_cast<size_t>(m)] = jet_product(factor_jet(rev, kp, a), factor_jet(rev, kp + factor_size(m), a));
    t.potential[static_cast<size_t>(m)] = factor_jet(rev, params_.data() + potential_joint_[static_cast<size_t>(m)], a);
  }
}

int LagrangianKernel::term_support(int term) const { return serial_chain_ ? term : 0; }

void LagrangianKernel::term_product(int term, const Eigen::VectorXd& v, Eigen::VectorXd& out) const {
  if (!serial_chain_) {
    out.noalias() = nu_ * v;
    return;
  }
  // Row and column `term` of nu: (nu v)_term sums the row, the rows below see v_term only.
  double sum = 0.0;
  for (int b = term; b < n_; ++b) sum += nu_(term, b) * v(b);
  for (int i = 0; i < term; ++i) out(i) = 0.0;
  out(term) = sum;
  for (int i = term + 1; i < n_; ++i) out(i) = nu_(i, term) * v(term);
}

void LagrangianKernel::write_term_weights(int term, double scale, Eigen::MatrixXd& out) const {
  if (!serial_chain_) {
    out = scale * nu_;
    return;
  }
  for (int b = term; b < n_; ++b) out(term, b) = out(b, term) = scale * nu_(term, b);
}

double LagrangianKernel::term_contraction(int term, const Eigen::MatrixXd& M) const {
  if (!serial_chain_) return nu_.cwiseProduct(M).sum();
  double sum = nu_(term, term) * M(term, term);
  for (int b = term + 1; b < n_; ++b) sum += nu_(term, b) * (M(term, b) + M(b, term));
  return sum;
}

void LagrangianKernel::velocity_products(const double* x1, const double* x2, PairTerms& t) const {
  const int n = n_;
  const Eigen::Map<const Eigen::VectorXd> qd1(x1 + n, n), qdd1(x1 + 2 * n, n), qd2(x2 + n, n), qdd2(x2 + 2 * n, n);
  t.e = qd1.cwiseProduct(qd2);
  t.v5 = qdd1.cwiseProduct(qd2);
  t.v7 = qdd2.cwiseProduct(qd1);
}

void LagrangianKernel::kinetic_term_quantities(const double* x1, const double* x2, int term, PairTerms& t) const {
  const int n = n_;
  const int first = first_kinetic_joint(term);
  if (!serial_chain_) {
    position_quantities(t.kinetic, t.P, t.g, t.gp, t.H, t.prefix, t.suffix);
  } else if (first == n) {  // the last term's position kernel is the constant 1
    t.P = 1.0;
    t.g.setZero();
    t.gp.setZero();
    t.H.setZero();
  } else {  // the term after this one was the last visited
    prepend_factor(t.kinetic[static_cast<size_t>(first)], first, t.P, t.g, t.gp, t.H);
  }
  const Eigen::Map<const Eigen::VectorXd> qd1(x1 + n, n), qd2(x2 + n, n);
  term_product(term, t.e, t.b);
  term_product(term, t.v5, t.a5);
  term_product(term, t.v7, t.c7);
  // g, g' and H vanish before `first`.
  t.P1 = t.P1p = t.Q = 0.0;
  for (int i = 0; i < first; ++i) t.h6(i) = t.h8(i) = 0.0;
  for (int i = first; i < n; ++i) {
    double h6 = 0.0, h8 = 0.0;
    for (int k = first; k < n; ++k) {
      h6 += t.H(k, i) * qd1(k);
      h8 += t.H(i, k) * qd2(k);
    }
    t.h6(i) = h6;
    t.h8(i) = h8;
    t.P1 += qd1(i) * t.g(i);
    t.P1p += qd2(i) * t.gp(i);
    t.Q += qd1(i) * h8;
  }
}

void LagrangianKernel::assemble_block(const double* x1, const double* x2, PairTerms& t,
                                      Eigen::Ref<Eigen::MatrixXd> K) const {
  const int n = n_;
  position_jets(x1, x2, t);
  velocity_products(x1, x2, t);
  const Eigen::Map<const Eigen::VectorXd> qd1(x1 + n, n), qdd1(x1 + 2 * n, n), qd2(x2 + n, n), qdd2(x2 + 2 * n, n);
  K.setZero();
  for (int term = num_kinetic_terms(); term-- > 0;) {
    kinetic_term_quantities(x1, x2, term, t);
    write_term_weights(term, t.P, t.nuP);
    write_term_weights(term, t.P1p, t.nuP1p);
    write_term_weights(term, t.P1, t.nuP1);
    write_term_weights(term, t.Q, t.nuQ);
    // The outer products of the notation, on the rows and columns where this
    // term's vectors can be non-zero.
    const double U = t.e.dot(t.b);
    const int lo = term_support(term);
    for (int j = lo; j < n; ++j)
      for (int i = lo; i < n; ++i)
        K(i, j) += -2.0 * qd2(i) * (t.a5(i) * t.gp(j) + t.b(i) * t.h6(j)) -
                   2.0 * qd1(j) * (t.g(i) * t.c7(j) + t.h8(i) * t.b(j)) + U * t.H(i, j);
  }
  add_symmetric_term(t.nuP, qdd1, qdd2, K);
  add_symmetric_term(t.nuP1p, qdd1, qd2, K);
  add_symmetric_term(t.nuP1, qd1, qdd2, K);
  add_symmetric_term(t.nuQ, qd1, qd2, K);
  position_quantities(t.potential, t.PV, t.gV, t.gpV, t.HV, t.prefix, t.suffix);
  K += t.HV;
  if (has_friction())
    for (int m = 0; m < n; ++m) K(m, m) += friction_covariance(m, qd1(m), qd2(m));
}

void LagrangianKernel::kinetic_monomial_weights(int joint, double* w) const {
  const double* f = params_.data() + kinetic_offset_[static_cast<size_t>(joint)];
  const double* g = f + factor_size(joint);
  // (f0 + f1 z1 z1' + f2 z2 z2') (g0 + g1 z1 z1' + g2 z2 z2'), expanded in monomials of z.
  if (!joints_.is_revolute(joint)) {
    w[0] = f[0] * g[0];
    w[1] = f[0] * g[1] + f[1] * g[0];
    w[2] = f[1] * g[1];
    return;
  }
  w[0] = f[0] * g[0];
  w[1] = f[0] * g[1] + f[1] * g[0];
  w[2] = f[0] * g[2] + f[2] * g[0];
  w[3] = f[1] * g[1];
  w[4] = f[2] * g[2];
  w[5] = f[1] * g[2] + f[2] * g[1];
}

void LagrangianKernel::potential_monomial_weights(int joint, double* w) const {
  const double* f = params_.data() + potential_joint_[static_cast<size_t>(joint)];
  for (int k = 0; k < factor_size(joint); ++k) w[k] = f[k];
}

Eigen::Vector4d LagrangianKernel::friction_features_at(int joint, double v) const {
  const int o = friction_offset_ + FrictionKernel::kNumParams * joint;
  return friction_features(v, log_params_(o + FrictionKernel::kCoulombVelocity),
                           log_params_(o + FrictionKernel::kStribeckVelocity));
}

Eigen::Vector4d LagrangianKernel::friction_variances(int joint) const {
  return params_.segment<4>(friction_offset_ + FrictionKernel::kNumParams * joint);
}

double LagrangianKernel::friction_covariance(int m, double v1, double v2) const {
  const Eigen::Vector4d f1 = friction_features_at(m, v1), f2 = friction_features_at(m, v2);
  return (friction_variances(m).array() * f1.array() * f2.array()).sum();
}

void LagrangianKernel::add_friction_gradient(int m, double v1, double v2, double w,
                                             Eigen::Ref<Eigen::VectorXd> grad) const {
  const int o = friction_offset_ + FrictionKernel::kNumParams * m;
  const double log_vc = log_params_(o + FrictionKernel::kCoulombVelocity);
  const double log_vr = log_params_(o + FrictionKernel::kStribeckVelocity);
  Eigen::Vector4d dc1, dr1, dc2, dr2;
  const Eigen::Vector4d f1 = friction_features(v1, log_vc, log_vr, &dc1, &dr1);
  const Eigen::Vector4d f2 = friction_features(v2, log_vc, log_vr, &dc2, &dr2);
  const Eigen::Array4d s = params_.segment<4>(o).array();
  grad.segment<4>(o) += (w * s * f1.array() * f2.array()).matrix();
  grad(o + FrictionKernel::kCoulombVelocity) += w * (s * (dc1.array() * f2.array() + f1.array() * dc2.array())).sum();
  grad(o + FrictionKernel::kStribeckVelocity) += w * (s * (dr1.array() * f2.array() + f1.array() * dr2.array())).sum();
}

LagrangianKernel::PairScratch::PairScratch(const LagrangianKernel& kernel)
    : terms_(std::make_unique<PairTerms>(kernel.n_)) {}
LagrangianKernel::PairScratch::~PairScratch() = default;
LagrangianKernel::PairScratch::PairScratch(PairScratch&&) noexcept = default;
LagrangianKernel::PairScratch& LagrangianKernel::PairScratch::operator=(PairScratch&&) noexcept = default;

void LagrangianKernel::torque_block(const double* x1, const double* x2, Eigen::Ref<Eigen::MatrixXd> block) const {
  PairTerms t(n_);
  assemble_block(x1, x2, t, block);
}

void LagrangianKernel::torque_block(const double* x1, const double* x2, PairScratch& scratch,
                                    Eigen::Ref<Eigen::MatrixXd> block) const {
  assemble_block(x1, x2, *scratch.terms_, block);
}

Eigen::MatrixXd LagrangianKernel::with_trigonometry(const Eigen::MatrixXd& X) const {
  const int n = n_;
  // Rows of X in contiguous memory: states are read one at a time.
  Eigen::MatrixXd A(5 * n, X.rows());
  A.topRows(3 * n) = X.leftCols(3 * n).transpose();
  for (Eigen::Index r = 0; r < X.rows(); ++r)
    for (int m = 0; m < n; ++m) {
      A(3 * n + m, r) = std::cos(X(r, m));
      A(4 * n + m, r) = std::sin(X(r, m));
    }
  return A;
}

void LagrangianKernel::fill_blocks(const Eigen::MatrixXd& X1, const Eigen::MatrixXd& X2, bool lower_only,
                                   Eigen::MatrixXd& K) const {
  const int n = n_;
  K.resize(X1.rows() * n, X2.rows() * n);
  const Eigen::MatrixXd A = with_trigonometry(X1), B = with_trigonometry(X2);
  run_range_tasks(lower_triangle_ranges(X1.rows()), [&](int, Eigen::Index r0, Eigen::Index r1) {
    PairTerms t(n);
    t.trigonometry_appended = true;
    Eigen::MatrixXd block(n, n);
    for (Eigen::Index r = r0; r < r1; ++r)
      for (Eigen::Index s = 0; s < (lower_only ? r + 1 : X2.rows()); ++s) {
        assemble_block(A.col(r).data(), B.col(s).data(), t, block);
        K.block(r * n, s * n, n, n) = block;
      }
  });
}

Eigen::MatrixXd LagrangianKernel::torque_covariance(const Eigen::MatrixXd& X1, const Eigen::MatrixXd& X2) const {
  Eigen::MatrixXd K;
  fill_blocks(X1, X2, false, K);
  return K;
}

void LagrangianKernel::torque_gram_lower(const Eigen::MatrixXd& X, Eigen::MatrixXd& K) const {
  fill_blocks(X, X, true, K);
}

void LagrangianKernel::add_pair_gradient(const double* x1, const double* x2, const Eigen::Ref<const Eigen::MatrixXd>& W,
                                         PairTerms& t, Eigen::Ref<Eigen::VectorXd> grad) const {
  const int n = n_;
  position_jets(x1, x2, t);
  velocity_products(x1, x2, t);
  const Eigen::Map<const Eigen::VectorXd> qd1(x1 + n, n), qdd1(x1 + 2 * n, n), qd2(x2 + n, n), qdd2(x2 + 2 * n, n);
  auto dot = [](const Jet& a, const Jet& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]; };
  // d<W, S(x, y)>/d nu_ab with the entries of nu independent, for the four S terms:
  // every term's share of them is a sum over its entries of nu.
  std::fill(t.kinetic_sensitivity.begin(), t.kinetic_sensitivity.end(), Jet{});
  symmetric_term_gradient(W, qdd1, qdd2, t.MP);
  symmetric_term_gradient(W, qdd1, qd2, t.MP1p);
  symmetric_term_gradient(W, qd1, qdd2, t.MP1);
  symmetric_term_gradient(W, qd1, qd2, t.MQ);

  for (int term = num_kinetic_terms(); term-- > 0;) {
    kinetic_term_quantities(x1, x2, term, t);
    const int first = first_kinetic_joint(term), lo = term_support(term);
    // W and W' times this term's vectors, on the rows the term can touch.
    double WH = 0.0;
    for (int i = lo; i < n; ++i) {
      double Wgp = 0.0, Wh6 = 0.0, Wtg = 0.0, Wth8 = 0.0;
      for (int k = first; k < n; ++k) {
        Wgp += W(i, k) * t.gp(k);
        Wh6 += W(i, k) * t.h6(k);
        Wtg += W(k, i) * t.g(k);
        Wth8 += W(k, i) * t.h8(k);
        if (i >= first) WH += W(i, k) * t.H(i, k);
      }
      t.Wgp(i) = Wgp, t.Wh6(i) = Wh6, t.Wtg(i) = Wtg, t.Wth8(i) = Wth8;
    }

    // Velocity weights of this term: G_ab = d<W, K>/d nu_ab with the entries of nu independent.
    auto G = [&](int a, int b) {
      return t.P * t.MP(a, b) + t.P1p * t.MP1p(a, b) + t.P1 * t.MP1(a, b) + t.Q * t.MQ(a, b) -
             2.0 * qd2(a) * (t.Wgp(a) * t.v5(b) + t.Wh6(a) * t.e(b)) -
             2.0 * qd1(a) * (t.Wtg(a) * t.v7(b) + t.Wth8(a) * t.e(b)) + WH * t.e(a) * t.e(b);
    };
    int k = 0;
    for (int a = 0; a < n; ++a)
      for (int c = a; c < n; ++c, ++k)
        if (!serial_chain_ || a == term) grad(k) += a == c ? nu_(a, a) * G(a, a) : nu_(a, c) * (G(a, c) + G(c, a));

    // Position parameters: <W, K> as a linear function of this term's position
    // quantities, on the joints from `first` on (the others' jets are constant).
    PositionCoefficients& kin = t.kin;
    kin.cP = term_contraction(term, t.MP);
    const double sP1p = term_contraction(term, t.MP1p), sP1 = term_contraction(term, t.MP1),
                 sQ = term_contraction(term, t.MQ), U = t.e.dot(t.b);
    for (int i = first; i < n; ++i) {
      double Wta5 = 0.0, Wc7 = 0.0, Wtb = 0.0, Wb = 0.0;
      for (int k2 = lo; k2 < n; ++k2) {
        Wta5 += W(k2, i) * qd2(k2) * t.a5(k2);
        Wc7 += W(i, k2) * qd1(k2) * t.c7(k2);
        Wtb += W(k2, i) * qd2(k2) * t.b(k2);
        Wb += W(i, k2) * qd1(k2) * t.b(k2);
      }
      kin.cgp(i) = sP1p * qd2(i) - 2.0 * Wta5;
      kin.cg(i) = sP1 * qd1(i) - 2.0 * Wc7;
      t.u(i) = Wtb;
      t.w(i) = Wb;
    }
    for (int j = first; j < n; ++j)
      for (int i = first; i < n; ++i)
        kin.cH(i, j) = sQ * qd1(i) * qd2(j) - 2.0 * qd1(i) * t.u(j) - 2.0 * t.w(i) * qd2(j) + U * W(i, j);
    position_sensitivities(t.kinetic, kin, first, t.sensitivity, t.jet_derivatives);
    for (int m = first; m < n; ++m)
      for (int e = 0; e < 4; ++e)
        t.kinetic_sensitivity[static_cast<size_t>(m)][e] += t.jet_derivatives[static_cast<size_t>(m)][e];
  }
  // <W, K> is linear in each joint's kinetic jet, which all terms share: the
  // jet's derivatives with respect to its factors' parameters are taken once,
  // against the sum of the terms' sensitivities.
  for (int m = 0; m < n; ++m) {
    const bool rev = joints_.is_revolute(m);
    const int fs = factor_size(m);
    const AnglePair& a = t.angles[static_cast<size_t>(m)];  // set by position_jets
    const Jet& dk = t.kinetic_sensitivity[static_cast<size_t>(m)];
    const int ko = kinetic_offset_[static_cast<size_t>(m)];
    const Jet f1 = factor_jet(rev, params_.data() + ko, a);
    const Jet f2 = factor_jet(rev, params_.data() + ko + fs, a);
    for (int p = 0; p < fs; ++p) {
      grad(ko + p) += dot(dk, jet_product(factor_jet_derivative(rev, params_.data() + ko, p, a), f2));
      grad(ko + fs + p) += dot(dk, jet_product(f1, factor_jet_derivative(rev, params_.data() + ko + fs, p, a)));
    }
  }

  PositionCoefficients& pot = t.pot;
  pot.cH = W;
  position_sensitivities(t.potential, pot, 0, t.sensitivity, t.jet_derivatives);
  for (int m = 0; m < n; ++m) {
    const bool rev = joints_.is_revolute(m);
    const AnglePair& a = t.angles[static_cast<size_t>(m)];
    const Jet& dv = t.jet_derivatives[static_cast<size_t>(m)];
    const int po = potential_joint_[static_cast<size_t>(m)];
    for (int p = 0; p < factor_size(m); ++p) grad(po + p) += dot(dv, factor_jet_derivative(rev, params_.data() + po, p, a));
    if (has_friction()) add_friction_gradient(m, qd1(m), qd2(m), W(m, m), grad);
  }
}

void LagrangianKernel::add_gradient(const Eigen::MatrixXd& X, const Eigen::MatrixXd& W_lower,
                                    Eigen::Ref<Eigen::VectorXd> grad) const {
  const int n = n_;
  const Eigen::MatrixXd A = with_trigonometry(X);
  const std::vector<std::ptrdiff_t> ranges = lower_triangle_ranges(X.rows());
  std::vector<Eigen::VectorXd> partial(ranges.size() - 1, Eigen::VectorXd::Zero(num_params()));
  run_range_tasks(ranges, [&](int range, Eigen::Index r0, Eigen::Index r1) {
    PairTerms t(n);
    t.trigonometry_appended = true;
    Eigen::VectorXd& g = partial[static_cast<size_t>(range)];
    Eigen::MatrixXd Wd(n, n);
    for (Eigen::Index r = r0; r < r1; ++r) {
      for (Eigen::Index s = 0; s < r; ++s) {  // the upper block (s, r) is the transpose: counted twice
        Wd = 2.0 * W_lower.block(r * n, s * n, n, n);  // into the sized buffer: no allocation per pair
        add_pair_gradient(A.col(r).data(), A.col(s).data(), Wd, t, g);
      }
      Wd = W_lower.block(r * n, r * n, n, n).selfadjointView<Eigen::Lower>();
      add_pair_gradient(A.col(r).data(), A.col(r).data(), Wd, t, g);
    }
  });
  for (const auto& g : partial) grad += g;
}

Eigen::RowVectorXd LagrangianKernel::kinetic_torque_covariance(const double* x, const Eigen::MatrixXd& X) const {
  const int n = n_;
  Eigen::RowVectorXd out = Eigen::RowVectorXd::Zero(X.rows() * n);
  PairTerms t(n);
  const Eigen::Map<const Eigen::VectorXd> qd(x + n, n);
  Eigen::VectorXd xs(3 * n);
  for (Eigen::Index s = 0; s < X.rows(); ++s) {
    xs = X.row(s).transpose();
    position_jets(x, xs.data(), t);
    velocity_products(x, xs.data(), t);
    for (int term = num_kinetic_terms(); term-- > 0;) {
      // The term's nu (qdd2 o qd) is c7, its nu e is b, and qd2.g' is P1p.
      kinetic_term_quantities(x, xs.data(), term, t);
      out.segment(s * n, n) +=
          (2.0 * qd.cwiseProduct(t.c7) * t.P + 2.0 * qd.cwiseProduct(t.b) * t.P1p - t.e.dot(t.b) * t.gp).transpose();
    }
  }
  return out;
}

Eigen::RowVectorXd LagrangianKernel::potential_torque_covariance(const double* x, const Eigen::MatrixXd& X) const {
  const int n = n_;
  Eigen::RowVectorXd out(X.rows() * n);
  PairTerms t(n);
  Eigen::VectorXd xs(3 * n);
  for (Eigen::Index s = 0; s < X.rows(); ++s) {
    xs = X.row(s).transpose();
    position_jets(x, xs.data(), t);
    position_quantities(t.potential, t.PV, t.gV, t.gpV, t.HV, t.prefix, t.suffix);
    out.segment(s * n, n) = t.gpV.transpose();
  }
  return out;
}

void LagrangianKernel::restrict_log_params(const Eigen::MatrixXd& X, Eigen::Ref<Eigen::VectorXd> lower,
                                           Eigen::Ref<Eigen::VectorXd> upper) const {
  if (!has_friction()) return;
  for (int m = 0; m < n_; ++m) {
    const int o = friction_offset_ + FrictionKernel::kNumParams * m;
    FrictionKernel(n_ + m).restrict_log_params(X, lower.segment<FrictionKernel::kNumParams>(o),
                                               upper.segment<FrictionKernel::kNumParams>(o));
  }
}

void LagrangianKernel::initialize(const Eigen::MatrixXd& X, double target_variance) {
  Eigen::VectorXd p = Eigen::VectorXd::Zero(num_params());  // velocity weights 1
  auto set_factor = [&](int offset, int m, double bias_share) {
    if (joints_.is_revolute(m)) {
      // cos^2 + sin^2 = 1: the factor is exactly 1 on the diagonal.
      p(offset) = std::log(bias_share);
      p(offset + 1) = p(offset + 2) = std::log(1.0 - bias_share);
    } else {
      const double ms = X.rows() > 0 ? X.col(m).squaredNorm() / static_cast<double>(X.rows()) : 0.0;
      p(offset) = std::log(bias_share);
      p(offset + 1) = std::log((1.0 - bias_share) / (ms > 1e-12 ? ms : 1.0));
    }
  };
  for (int m = 0; m < n_; ++m) {
    const int ko = kinetic_offset_[static_cast<size_t>(m)];
    set_factor(ko, m, 0.25);  // the two factors start apart, as GIP's
    set_factor(ko + factor_size(m), m, 0.75);
    set_factor(potential_joint_[static_cast<size_t>(m)], m, 0.5);
  }
  set_log_params(p);

  // Measure the prior torque variance of each energy on (up to 200 of) the
  // states, then scale: the kinetic part is linear in the velocity weights,
  // the potential part is a product of n factors.
  const Eigen::Index rows = std::min<Eigen::Index>(X.rows(), 200);
  const Eigen::Index step = rows > 0 ? X.rows() / rows : 1;
  double kinetic = 0.0, potential = 0.0;
  PairTerms t(n_);
  Eigen::MatrixXd block(n_, n_);
  Eigen::VectorXd x(3 * n_);
  for (Eigen::Index r = 0; r < rows; ++r) {
    x = X.row(r * step).transpose();
    assemble_block(x.data(), x.data(), t, block);
    potential += t.HV.trace();
    kinetic += block.trace() - t.HV.trace();
    if (has_friction())
      for (int m = 0; m < n_; ++m) kinetic -= friction_covariance(m, x(n_ + m), x(n_ + m));
  }
  const double count = static_cast<double>(std::max<Eigen::Index>(rows, 1) * n_);
  kinetic /= count;
  potential /= count;
  const double half = 0.5 * target_variance;
  if (kinetic > 1e-300) p.head(num_velocity_weights()).array() += std::log(half / kinetic);
  if (potential > 1e-300) {
    const double per_factor = std::log(half / potential) / n_;
    for (int m = 0; m < n_; ++m)
      p.segment(potential_joint_[static_cast<size_t>(m)], factor_size(m)).array() += per_factor;
  }
  if (has_friction())
    for (int m = 0; m < n_; ++m) {
      FrictionKernel friction(n_ + m);
      friction.initialize(X, 0.25 * target_variance);
      p.segment<FrictionKernel::kNumParams>(friction_offset_ + FrictionKernel::kNumParams * m) = friction.log_params();
    }
  set_log_params(p);
}

}  // namespace gipdyn
