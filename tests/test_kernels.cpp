// Kernel values and analytic gradients, against finite differences, a naive
// evaluation of the GIP formula of docs/method.md, and the unfused composition.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "gipdyn/detail/factor_pair_product.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/kernels/composite_kernels.hpp"
#include "gipdyn/kernels/friction_kernel.hpp"
#include "gipdyn/kernels/gip_kernel.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/kernels/linear_kernel.hpp"
#include "gipdyn/kernels/parametric_kernel.hpp"
#include "gipdyn/kernels/rbf_kernel.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::random_inputs;
using test::random_vector;

const char* kJointStrings[] = {"R", "P", "RRPR", "RRRRRR", "PRPRRR"};

double max_abs(const Eigen::MatrixXd& M) { return M.cwiseAbs().maxCoeff(); }

// dK/dlog(theta_p) against a 4th-order central difference of cross().
void expect_gradient_matrices_match(Kernel& k, const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2,
                                    const std::string& what) {
  const Eigen::VectorXd p0 = k.log_params();
  const double h = 1e-3;
  for (int p = 0; p < k.num_params(); ++p) {
    Eigen::MatrixXd dK;
    k.gradient_matrix(Z1, Z2, p, dK);
    Eigen::MatrixXd fd = Eigen::MatrixXd::Zero(Z1.rows(), Z2.rows()), K;
    const double steps[4] = {2 * h, h, -h, -2 * h}, weights[4] = {-1, 8, -8, 1};
    for (int s = 0; s < 4; ++s) {
      Eigen::VectorXd pp = p0;
      pp(p) += steps[s];
      k.set_log_params(pp);
      k.cross(Z1, Z2, K);
      fd += weights[s] * K;
    }
    fd /= 12 * h;
    k.set_log_params(p0);
    Eigen::MatrixXd Kref;
    k.cross(Z1, Z2, Kref);
    const double scale = std::max(max_abs(fd), 1e-8 * max_abs(Kref));
    EXPECT_LT(max_abs(dK - fd) / scale, 1e-6) << what << " parameter " << k.param_names()[static_cast<size_t>(p)];
  }
}

// contract(Z, W) equals sum_ij W_ij dK_ij for a random symmetric W, and the
// lower-triangle NLL contraction equals the full one.
void expect_contractions_match(const Kernel& k, const Eigen::MatrixXd& Z, const std::string& what) {
  const Eigen::Index N = Z.rows();
  Eigen::MatrixXd W = test::random_matrix(N, N, -1.0, 1.0, 903);
  W = (W + W.transpose()).eval();
  KernelScratch scratch;
  Eigen::VectorXd g = Eigen::VectorXd::Zero(k.num_params());
  k.contract(Z, W, g, scratch);
  Eigen::VectorXd ref(k.num_params());
  for (int p = 0; p < k.num_params(); ++p) {
    Eigen::MatrixXd dK;
    k.gradient_matrix(Z, Z, p, dK);
    ref(p) = (W.array() * dK.array()).sum();
  }
  EXPECT_LT((g - ref).norm() / ref.norm(), 1e-10) << what << ": contract";

  const Eigen::VectorXd alpha = test::random_vector(N, -1.0, 1.0, 904);
  Eigen::MatrixXd Kinv = test::random_matrix(N, N, -1.0, 1.0, 905);
  Kinv = (Kinv + Kinv.transpose()).eval();
  Eigen::MatrixXd Kinv_lower = Kinv;
  Kinv_lower.triangularView<Eigen::StrictlyUpper>().setConstant(std::nan(""));  // must not be read
  Eigen::VectorXd g_nll = Eigen::VectorXd::Zero(k.num_params()), g_full = g_nll;
  k.contract_nll(Z, alpha, Kinv_lower, g_nll, scratch);
  k.contract(Z, alpha * alpha.transpose() - Kinv, g_full, scratch);
  EXPECT_LT((g_nll - g_full).norm() / g_full.norm(), 1e-10) << what << ": contract_nll";
}

TEST(LinearKernel, ValueAndGradients) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  const Eigen::MatrixXd Z1 = fm.compute(random_inputs(fm.joints(), 7, 1));
  const Eigen::MatrixXd Z2 = fm.compute(random_inputs(fm.joints(), 5, 2));
  LinearKernel k({12, 13, 14}, true, "lin", {"a", "b", "c"});
  k.set_log_params(random_vector(4, -1, 1, 3));
  Eigen::MatrixXd K;
  k.cross(Z1, Z2, K);
  const Eigen::VectorXd w = k.log_params().array().exp();
  const double expected = w(0) + w(1) * Z1(3, 12) * Z2(4, 12) + w(2) * Z1(3, 13) * Z2(4, 13) + w(3) * Z1(3, 14) * Z2(4, 14);
  EXPECT_NEAR(K(3, 4), expected, 1e-12 * std::abs(expected));
  EXPECT_EQ(k.param_names()[0], "lin.s0");
  EXPECT_EQ(k.param_names()[2], "lin.l_b");
  expect_gradient_matrices_match(k, Z1, Z2, "linear");
  expect_contractions_match(k, Z1, "linear");
  LinearKernel nobias({12}, false, "nb", {"x"});
  EXPECT_EQ(nobias.num_params(), 1);
  expect_gradient_matrices_match(nobias, Z1, Z2, "linear without bias");
}

TEST(CompositeKernels, MpkProductAndSumGradients) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  const Eigen::MatrixXd Z1 = fm.compute(random_inputs(fm.joints(), 6, 4));
  const Eigen::MatrixXd Z2 = fm.compute(random_inputs(fm.joints(), 4, 5));
  auto mpk3 = make_mpk(fm.position_group(0), 3, "m", {"cos", "sin"});
  mpk3->set_log_params(random_vector(mpk3->num_params(), -1, 0.5, 6));
  EXPECT_EQ(mpk3->num_params(), 9);
  EXPECT_EQ(mpk3->param_names()[3], "m.factor2.s0");
  // MPK_3 equals the product of its three factors written out.
  Eigen::MatrixXd K;
  mpk3->cross(Z1, Z2, K);
  const Eigen::VectorXd w = mpk3->log_params().array().exp();
  double expected = 1.0;
  for (int s = 0; s < 3; ++s)
    expected *= w(3 * s) + w(3 * s + 1) * Z1(2, 12) * Z2(1, 12) + w(3 * s + 2) * Z1(2, 13) * Z2(1, 13);
  EXPECT_NEAR(K(2, 1), expected, 1e-12 * std::abs(expected));
  expect_gradient_matrices_match(*mpk3, Z1, Z2, "mpk3");
  expect_contractions_match(*mpk3, Z1, "mpk3");

  std::vector<std::unique_ptr<Kernel>> terms;
  terms.push_back(std::move(mpk3));
  terms.push_back(std::make_unique<RbfKernel>(std::vector<int>{0, 1, 4}, std::vector<std::string>{"a", "b", "c"}));
  SumKernel sum(std::move(terms));
  sum.set_log_params(random_vector(sum.num_params(), -1, 0.5, 7));
  expect_gradient_matrices_match(sum, Z1, Z2, "mpk3 + rbf");
  expect_contractions_match(sum, Z1, "mpk3 + rbf");
}

TEST(RbfKernel, ValueAndGradients) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  const Eigen::MatrixXd Z1 = fm.compute(random_inputs(fm.joints(), 7, 8));
  const Eigen::MatrixXd Z2 = fm.compute(random_inputs(fm.joints(), 6, 9));
  auto k = make_kernel("rbf", fm, 0);
  k->set_log_params(random_vector(k->num_params(), -0.5, 1.0, 10));
  Eigen::MatrixXd K;
  k->cross(Z1, Z2, K);
  const Eigen::VectorXd p = k->log_params();
  double d2 = 0.0;
  for (int c = 0; c < 12; ++c) d2 += std::pow((Z1(2, c) - Z2(3, c)) / std::exp(p(1 + c)), 2);
  EXPECT_NEAR(K(2, 3), std::exp(p(0)) * std::exp(-0.5 * d2), 1e-12);
  EXPECT_EQ(k->param_names()[1], "rbf.lengthscale_q1");
  expect_gradient_matrices_match(*k, Z1, Z2, "rbf");
  expect_contractions_match(*k, Z1, "rbf");
}

// A sum's NLL contraction runs its fused children (GIP) on alpha and Kinv and
// shares one W among the others: every mix must equal the contraction with W.
TEST(CompositeKernels, SumNllContractionOfFusedAndUnfusedChildren) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  const Eigen::MatrixXd Z = fm.compute(random_inputs(fm.joints(), 9, 85));
  for (const char* name : {"gip+rbf", "gip+friction", "gip+friction+rbf", "gip-friction+rbf", "gip-envelope+friction"}) {
    auto k = make_kernel(name, fm, 1);
    k->set_log_params(random_vector(k->num_params(), -0.5, 0.5, 86));
    expect_contractions_match(*k, Z, name);
  }
}

// A product's contraction reuses the children's Gram matrices its gram_lower
// left in the scratch, and gives the bits a fresh scratch gives; it computes
// them again when the hyperparameters, the rows' contents or the kernel changed.
TEST(CompositeKernels, ContractionAfterGramLowerReusesTheChildrensMatricesOnlyWhileTheyHold) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  Eigen::MatrixXd Z = fm.compute(random_inputs(fm.joints(), 30, 87));
  const Eigen::Index N = Z.rows();
  const Eigen::VectorXd alpha = test::random_vector(N, -1.0, 1.0, 88);
  Eigen::MatrixXd Kinv = test::random_matrix(N, N, -1.0, 1.0, 89);
  Kinv = (Kinv + Kinv.transpose()).eval();
  for (const char* name : {"gip-envelope", "gip-envelope+friction"}) {
    SCOPED_TRACE(name);
    auto k = make_kernel(name, fm, 1);
    const Eigen::VectorXd p1 = random_vector(k->num_params(), -0.5, 0.5, 90);
    const Eigen::VectorXd p2 = random_vector(k->num_params(), -0.5, 0.5, 91);
    // The gradient of a scratch that never saw gram_lower.
    const auto fresh = [&](const Eigen::MatrixXd& rows) {
      KernelScratch clean;
      Eigen::VectorXd g = Eigen::VectorXd::Zero(k->num_params());
      k->contract_nll(rows, alpha, Kinv, g, clean);
      return g;
    };
    KernelScratch scratch;
    Eigen::MatrixXd K;
    Eigen::VectorXd g = Eigen::VectorXd::Zero(k->num_params());
    // One evaluation: gram_lower, then the contraction at the same hyperparameters.
    k->set_log_params(p1);
    k->gram_lower(Z, K, scratch);
    k->contract_nll(Z, alpha, Kinv, g, scratch);
    EXPECT_EQ(g, fresh(Z));
    Eigen::MatrixXd Kref;
    k->cross(Z, Z, Kref);
    EXPECT_EQ(Eigen::MatrixXd(K.triangularView<Eigen::Lower>()), Eigen::MatrixXd(Kref.triangularView<Eigen::Lower>()));
    // New hyperparameters since gram_lower: the kept matrices are not used.
    k->set_log_params(p2);
    g.setZero();
    k->contract_nll(Z, alpha, Kinv, g, scratch);
    EXPECT_EQ(g, fresh(Z));
    // The same matrix object with other contents.
    k->gram_lower(Z, K, scratch);
    Z(3, 2) += 0.25;
    g.setZero();
    k->contract_nll(Z, alpha, Kinv, g, scratch);
    EXPECT_EQ(g, fresh(Z));
    // A copy of the kernel (another instance, same hyperparameters) recomputes and agrees.
    k->gram_lower(Z, K, scratch);
    const auto copy = k->clone();
    g.setZero();
    copy->contract_nll(Z, alpha, Kinv, g, scratch);
    EXPECT_EQ(g, fresh(Z));
    EXPECT_NE(copy->instance(), k->instance());
  }
}

// The control-loop mean k(z, Z) alpha through a plan (the friction part folded
// into four weights) must equal the kernel row dotted with alpha, for every
// kernel with a friction part and for one without; an empty plan falls back.
TEST(MeanPlan, PlannedMeanEqualsTheRowDottedWithAlpha) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  const Eigen::MatrixXd Z = fm.compute(random_inputs(fm.joints(), 30, 81));
  const Eigen::MatrixXd Zq = fm.compute(random_inputs(fm.joints(), 5, 82));
  const Eigen::VectorXd alpha = random_vector(30, -2.0, 2.0, 83);
  for (const char* name : {"gip-envelope+friction", "gip+friction", "gip+friction+rbf", "gip+rbf"}) {
    auto k = make_kernel(name, fm, 1);
    k->set_log_params(random_vector(k->num_params(), -0.5, 0.5, 84));
    MeanPlan plan, empty;
    k->plan_mean(Z, alpha, plan);
    Eigen::VectorXd krow(30), row(30);
    KernelScratch scratch;
    for (int q = 0; q < 5; ++q) {
      const Eigen::VectorXd z = Zq.row(q).transpose();
      k->row(z.data(), Z, row, scratch);
      const double expected = row.dot(alpha), scale = row.cwiseProduct(alpha).cwiseAbs().sum();
      EXPECT_NEAR(k->mean_one(z.data(), Z, alpha, plan, krow, scratch), expected, 1e-13 * scale) << name;
      EXPECT_NEAR(k->mean_one(z.data(), Z, alpha, empty, krow, scratch), expected, 1e-13 * scale) << name;
    }
  }
}

// pp's k(z, Z) for one query (a predictive variance's) reads the regressor of Z
// that the scratch keeps: it must equal cross() for every joint sharing one
// scratch, with and without friction, also after Z's rows change in place.
TEST(ParametricKernel, RowFromTheKeptRegressorEqualsCrossAndFollowsZ) {
  const auto robot = std::make_shared<const RobotModel>(load_robot("ur10"));
  const JointTypes joints = robot->joint_types();
  const Eigen::MatrixXd Zq = random_inputs(joints, 3, 92);
  KernelScratch scratch;
  for (bool friction : {false, true}) {
    Eigen::MatrixXd Z = random_inputs(joints, 25, 91);
    for (int round = 0; round < 2; ++round) {
      if (round == 1) Z.row(7) = Zq.row(0);  // the same matrix, another row 7
      for (int j = 0; j < robot->num_joints(); ++j) {
        ParametricKernel k(robot, j, friction);
        k.set_log_params(random_vector(k.num_params(), -1.0, 1.0, 93 + j));
        Eigen::MatrixXd K;
        k.cross(Zq, Z, K);
        Eigen::VectorXd row(Z.rows()), diagonal;
        k.diagonal(Zq, diagonal);
        for (int q = 0; q < Zq.rows(); ++q) {
          const Eigen::VectorXd z = Zq.row(q).transpose();
          k.row(z.data(), Z, row, scratch);
          EXPECT_LT((row.transpose() - K.row(q)).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + K.row(q).cwiseAbs().maxCoeff()))
              << "round " << round << " friction " << friction << " joint " << j + 1 << " query " << q;
          // k(z, z) from the query's regressor the scratch keeps.
          EXPECT_NEAR(k.self(z.data(), static_cast<int>(z.size()), scratch), diagonal(q), 1e-12 * (1.0 + diagonal(q)))
              << "round " << round << " friction " << friction << " joint " << j + 1 << " query " << q;
        }
      }
    }
  }
}

// A lengthscale far below the inputs' size (the optimiser tries such points on
// logs with repeated rows): |a|^2 + |b|^2 - 2 a.b of the scaled inputs would
// cancel to noise, and the matrix would not even be positive semidefinite.
TEST(RbfKernel, TinyLengthscalesKeepDistancesExactAndTheMatrixPositiveDefinite) {
  RbfKernel k({0, 1}, {"a", "b"});
  Eigen::MatrixXd Z(8, 2);
  Z << 1.5, -2.0, 1.5, -2.0, 1.5 + 1e-8, -2.0, 1.5 + 3e-8, -2.0 + 2e-8,  //
      -0.7, 0.3, -0.7, 0.3, 0.9, -2.0, 1.5, -2.0 + 1e-8;
  for (const double lengthscale : {1e-7, 1e-8}) {
    k.set_log_params(Eigen::Vector3d(0.3, std::log(lengthscale), std::log(lengthscale)));
    Eigen::MatrixXd K;
    k.cross(Z, Z, K);
    const double variance = std::exp(0.3);
    Eigen::MatrixXd W = test::random_matrix(8, 8, -1.0, 1.0, 906);
    W = (W + W.transpose()).eval();
    Eigen::Vector3d reference = Eigen::Vector3d::Zero();
    for (Eigen::Index i = 0; i < 8; ++i)
      for (Eigen::Index j = 0; j < 8; ++j) {
        const double da = (Z(i, 0) - Z(j, 0)) / lengthscale, db = (Z(i, 1) - Z(j, 1)) / lengthscale;
        const double kij = variance * std::exp(-0.5 * (da * da + db * db));
        EXPECT_NEAR(K(i, j), kij, 1e-6 * variance) << "lengthscale " << lengthscale << ", entry " << i << "," << j;
        reference += W(i, j) * kij * Eigen::Vector3d(1.0, da * da, db * db);
      }
    Eigen::MatrixXd noisy = K;
    noisy.diagonal().array() += 1e-6 * variance;
    EXPECT_EQ(noisy.llt().info(), Eigen::Success) << "lengthscale " << lengthscale;

    KernelScratch scratch;
    Eigen::VectorXd g = Eigen::VectorXd::Zero(3), g_cross = g;
    k.contract(Z, W, g, scratch);
    k.contract_cross(Z, Z, W, g_cross, scratch);
    EXPECT_LT((g - reference).norm(), 1e-6 * reference.norm()) << "lengthscale " << lengthscale;
    EXPECT_LT((g_cross - reference).norm(), 1e-6 * reference.norm()) << "lengthscale " << lengthscale;
  }
}

// docs/method.md section 12 written out: offset, viscous, tanh Coulomb and Stribeck.
TEST(FrictionKernel, ValueGradientsAndFastPathsMatchTheFormula) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  const Eigen::MatrixXd Z1 = fm.compute(random_inputs(fm.joints(), 9, 21));
  const Eigen::MatrixXd Z2 = fm.compute(random_inputs(fm.joints(), 7, 22));
  FrictionKernel k(fm.qd(2), "joint3.friction");
  k.set_log_params(random_vector(k.num_params(), -1.0, 0.5, 23));
  const Eigen::VectorXd w = k.log_params().array().exp();
  auto naive = [&](double v, double u) {
    auto c = [&](double x) { return std::tanh(x / w(4)); };
    auto r = [&](double x) { return std::exp(-std::pow(x / w(5), 2)) * c(x); };
    return w(0) + w(1) * v * u + w(2) * c(v) * c(u) + w(3) * r(v) * r(u);
  };
  Eigen::MatrixXd K;
  k.cross(Z1, Z2, K);
  for (Eigen::Index i = 0; i < Z1.rows(); ++i)
    for (Eigen::Index j = 0; j < Z2.rows(); ++j) EXPECT_NEAR(K(i, j), naive(Z1(i, fm.qd(2)), Z2(j, fm.qd(2))), 1e-12);
  EXPECT_EQ(k.param_names()[4], "joint3.friction.v_coulomb");
  expect_gradient_matrices_match(k, Z1, Z2, "friction");
  expect_contractions_match(k, Z1, "friction");
  KernelScratch scratch;
  Eigen::VectorXd row(Z2.rows()), d;
  const Eigen::RowVectorXd z4 = Z1.row(4);
  k.row(z4.data(), Z2, row, scratch);
  EXPECT_LT((row.transpose() - K.row(4)).cwiseAbs().maxCoeff(), 1e-12);
  k.diagonal(Z1, d);
  const Eigen::RowVectorXd z = Z1.row(2);
  EXPECT_NEAR(k.self(z.data(), fm.feature_dim(), scratch), d(2), 1e-12);
  EXPECT_NEAR(d(2), naive(z(fm.qd(2)), z(fm.qd(2))), 1e-12);
  // Only the joint's own velocity matters.
  Eigen::MatrixXd Z3 = Z1;
  Z3.col(fm.qd(0)).setRandom();
  Z3.col(fm.qdd(2)).setRandom();
  Eigen::MatrixXd K3;
  k.cross(Z3, Z2, K3);
  EXPECT_EQ((K3.topRows(Z1.rows()) - K).cwiseAbs().maxCoeff(), 0.0);
}

TEST(FrictionKernel, StartsWithEachTermAtAQuarterOfTheTargetAndSmoothingBelowTheSpeeds) {
  const FeatureMap fm(JointTypes::parse("RR"));
  const Eigen::MatrixXd Z = fm.compute(random_inputs(fm.joints(), 200, 24));
  FrictionKernel k(fm.qd(1));
  k.initialize(Z, 2.0);
  Eigen::VectorXd d;
  k.diagonal(Z, d);
  EXPECT_NEAR(d.mean(), 2.0, 1e-9);  // four terms, each a quarter on average
  const double rms = std::sqrt(Z.col(fm.qd(1)).squaredNorm() / 200.0);
  EXPECT_NEAR(std::exp(k.log_params()(FrictionKernel::kCoulombVelocity)), 0.05 * rms, 1e-12);
  EXPECT_NEAR(std::exp(k.log_params()(FrictionKernel::kStribeckVelocity)), 0.2 * rms, 1e-12);
}

// docs/method.md section 2 written out directly from raw inputs, with the parameter layout
// documented in gip_kernel.hpp: per joint two factors [s0, l...], then the
// acceleration factor [s0, l_qdd..., l_qdqd...], then friction [l_v, l_c].
double naive_gip(const JointTypes& joints, const Eigen::VectorXd& logp, const Eigen::RowVectorXd& x,
                 const Eigen::RowVectorXd& y, int friction_joint) {
  const int n = joints.size();
  const Eigen::VectorXd w = logp.array().exp();
  int o = 0;
  double k = 1.0;
  for (int b = 0; b < n; ++b) {
    for (int s = 0; s < 2; ++s) {
      double f = w(o++);
      if (joints.is_revolute(b)) {
        f += w(o++) * std::cos(x(b)) * std::cos(y(b));
        f += w(o++) * std::sin(x(b)) * std::sin(y(b));
      } else {
        f += w(o++) * x(b) * y(b);
      }
      k *= f;
    }
  }
  double acc = w(o++);
  for (int i = 0; i < n; ++i) acc += w(o++) * x(2 * n + i) * y(2 * n + i);
  for (int i = 0; i < n; ++i)
    for (int j = i; j < n; ++j) acc += w(o++) * (x(n + i) * x(n + j)) * (y(n + i) * y(n + j));
  k *= acc;
  if (friction_joint >= 0) {
    const double vx = x(n + friction_joint), vy = y(n + friction_joint);
    k += w(o++) * vx * vy;
    k += w(o++) * ((vx > 0) - (vx < 0)) * ((vy > 0) - (vy < 0));
  }
  EXPECT_EQ(o, logp.size());
  return k;
}

// The GIP kernel's innermost loop runs in AVX2 or AVX-512 copies where the CPU
// has them (the rest of the library stays at the baseline instruction set):
// every copy this CPU runs, on lengths that leave vector tails, gives the bits
// of the plain formula, so a model predicts the same on every CPU.
TEST(FactorPairProduct, EveryInstructionSetThisCpuRunsGivesThePlainLoopsBits) {
  using detail::VectorIsa;
  const double p[3] = {0.7, -1.3, 0.45}, q[3] = {1.9, 0.35, -2.1};
  int compared = 0;
  for (const std::ptrdiff_t m : {0, 1, 3, 8, 13, 64, 1001}) {
    const int size = static_cast<int>(m);
    const Eigen::VectorXd u = random_vector(size, -2.0, 2.0, 21), v = random_vector(size, -2.0, 2.0, 22),
                          col = random_vector(size, -1.0, 1.0, 23);
    for (const bool with_v : {true, false}) {
      Eigen::VectorXd expected = col;
      for (std::ptrdiff_t i = 0; i < m; ++i) {
        double x = p[0] + p[1] * u(i), y = q[0] + q[1] * u(i);
        if (with_v) x = x + p[2] * v(i), y = y + q[2] * v(i);
        expected(i) = col(i) * (x * y);
      }
      for (const VectorIsa isa : {VectorIsa::kBaseline, VectorIsa::kAvx2, VectorIsa::kAvx512}) {
        const bool runs = static_cast<int>(isa) <= static_cast<int>(detail::cpu_vector_isa());
        Eigen::VectorXd out = col;
        ASSERT_EQ(detail::multiply_by_factor_pair(isa, out.data(), u.data(), with_v ? v.data() : nullptr, m, p, q),
                  runs);
        if (!runs) {
          ASSERT_TRUE(out == col) << "an ISA the CPU lacks must leave the column untouched";
          continue;
        }
        for (std::ptrdiff_t i = 0; i < m; ++i)
          ASSERT_EQ(out(i), expected(i)) << detail::vector_isa_name(isa) << ", m = " << m << ", i = " << i;
        ++compared;
      }
      Eigen::VectorXd dispatched = col;
      detail::multiply_by_factor_pair(dispatched.data(), u.data(), with_v ? v.data() : nullptr, m, p, q);
      EXPECT_TRUE(dispatched == expected) << "m = " << m;
    }
  }
  EXPECT_GE(compared, 14);  // the baseline at least, with and without v, at every length
}

// Runs `run(isa, out)` (false: the CPU lacks the ISA) from `start` for every
// ISA, and the dispatched copy (`run(nullopt, out)`): each copy this CPU runs
// must give `expected` exactly, and one it lacks must leave `start` alone.
// Returns how many ISAs were compared.
template <class Run>
int expect_every_isa_gives(const Eigen::VectorXd& start, const Eigen::VectorXd& expected, const std::string& what,
                           Run run) {
  using detail::VectorIsa;
  int compared = 0;
  for (const VectorIsa isa : {VectorIsa::kBaseline, VectorIsa::kAvx2, VectorIsa::kAvx512}) {
    const bool runs = static_cast<int>(isa) <= static_cast<int>(detail::cpu_vector_isa());
    Eigen::VectorXd out = start;
    EXPECT_EQ(run(std::optional<VectorIsa>(isa), out), runs) << what;
    if (!runs) {
      EXPECT_TRUE(out == start) << "an ISA the CPU lacks must leave the outputs untouched: " << what;
      continue;
    }
    EXPECT_TRUE(out == expected) << detail::vector_isa_name(isa) << ", " << what;
    ++compared;
  }
  Eigen::VectorXd dispatched = start;
  run(std::optional<VectorIsa>(), dispatched);
  EXPECT_TRUE(dispatched == expected) << "dispatched, " << what;
  return compared;
}

// The acceleration factors of every joint's row at once, in each ISA's copy:
// the bits of the plain sum in order, for any number of outputs (groups of
// eight and a remainder) and lengths that leave vector tails.
TEST(AffineCombinations, EveryInstructionSetThisCpuRunsGivesThePlainSumsBits) {
  using detail::VectorIsa;
  int compared = 0;
  for (const int columns : {1, 3, 6, 8, 11})
    for (const int count : {0, 1, 6, 27})
      for (const std::ptrdiff_t m : {0, 1, 3, 4, 13, 1001}) {
        const std::ptrdiff_t stride = m + 5, w_stride = count + 2, out_stride = m + 3;
        const Eigen::VectorXd a = random_vector(static_cast<int>(stride * std::max(count, 1)), -2.0, 2.0, 31),
                              W = random_vector(static_cast<int>(w_stride * columns), -1.5, 1.5, 32),
                              c = random_vector(columns, -1.0, 1.0, 33);
        const Eigen::VectorXd untouched = random_vector(static_cast<int>(out_stride * columns), -1.0, 1.0, 34);
        Eigen::VectorXd expected = untouched;
        for (int j = 0; j < columns; ++j)
          for (std::ptrdiff_t i = 0; i < m; ++i) {
            double sum = c(j);
            for (int d = 0; d < count; ++d) sum = sum + W(d + j * w_stride) * a(d * stride + i);
            expected(j * out_stride + i) = sum;
          }
        const std::string what =
            std::to_string(columns) + " outputs, " + std::to_string(count) + " inputs, m = " + std::to_string(m);
        compared += expect_every_isa_gives(untouched, expected, what, [&](std::optional<VectorIsa> isa, Eigen::VectorXd& out) {
          if (!isa) {
            detail::set_affine_combinations(out.data(), out_stride, columns, m, c.data(), a.data(), stride, W.data(),
                                            w_stride, count);
            return true;
          }
          return detail::set_affine_combinations(*isa, out.data(), out_stride, columns, m, c.data(), a.data(), stride,
                                                 W.data(), w_stride, count);
        });
      }
  EXPECT_GE(compared, 5 * 4 * 6);  // the baseline at least, on every shape
}

// The transposed product behind every joint's affine coefficients, in each
// ISA's copy: the bits of four lane sums added in lane order, then the rows
// past the last group of four, for odd and even input counts (pairs and a
// remainder), groups of six outputs and a remainder, and lengths with tails.
TEST(ColumnDotProducts, EveryInstructionSetThisCpuRunsGivesTheLaneSumsBits) {
  using detail::VectorIsa;
  int compared = 0;
  for (const int columns : {1, 4, 6, 7, 13})
    for (const int count : {1, 2, 5, 27})
      for (const std::ptrdiff_t m : {0, 1, 3, 4, 13, 1001}) {
        const std::ptrdiff_t stride = m + 5, u_stride = m + 2, out_stride = count + 3;
        const Eigen::VectorXd a = random_vector(static_cast<int>(stride * count), -2.0, 2.0, 41),
                              U = random_vector(static_cast<int>(u_stride * columns), -1.5, 1.5, 42),
                              start = random_vector(static_cast<int>(out_stride * columns), -1.0, 1.0, 43);
        Eigen::VectorXd expected = start;
        for (int j = 0; j < columns; ++j)
          for (int d = 0; d < count; ++d) {
            double lane[4] = {0.0, 0.0, 0.0, 0.0};
            const std::ptrdiff_t whole = m - m % 4;
            for (std::ptrdiff_t i = 0; i < whole; ++i) lane[i % 4] = lane[i % 4] + a(d * stride + i) * U(j * u_stride + i);
            double total = ((lane[0] + lane[1]) + lane[2]) + lane[3];
            for (std::ptrdiff_t i = whole; i < m; ++i) total = total + a(d * stride + i) * U(j * u_stride + i);
            expected(d + j * out_stride) = start(d + j * out_stride) + total;
          }
        const std::string what =
            std::to_string(count) + " inputs, " + std::to_string(columns) + " columns, m = " + std::to_string(m);
        compared += expect_every_isa_gives(start, expected, what, [&](std::optional<VectorIsa> isa, Eigen::VectorXd& out) {
          if (!isa) {
            detail::add_column_dot_products(out.data(), out_stride, count, columns, m, a.data(), stride, U.data(),
                                            u_stride);
            return true;
          }
          return detail::add_column_dot_products(*isa, out.data(), out_stride, count, columns, m, a.data(), stride,
                                                 U.data(), u_stride);
        });
      }
  EXPECT_GE(compared, 5 * 4 * 6);  // the baseline at least, on every shape
}

class GipKernelTest : public ::testing::TestWithParam<const char*> {};

TEST_P(GipKernelTest, ValueMatchesNaiveFormula) {
  const JointTypes joints = JointTypes::parse(GetParam());
  const FeatureMap fm(joints);
  const Eigen::MatrixXd X1 = random_inputs(joints, 6, 11), X2 = random_inputs(joints, 5, 12);
  const Eigen::MatrixXd Z1 = fm.compute(X1), Z2 = fm.compute(X2);
  for (int friction : {-1, joints.size() - 1}) {
    GipKernel k(fm, friction);
    const int n = joints.size();
    const int expected_params = 2 * (3 * joints.num_revolute() + 2 * joints.num_prismatic()) + 1 + n + n * (n + 1) / 2 +
                                (friction >= 0 ? 2 : 0);
    ASSERT_EQ(k.num_params(), expected_params);
    k.set_log_params(random_vector(k.num_params(), -1.0, 0.3, 13));
    Eigen::MatrixXd K;
    k.cross(Z1, Z2, K);
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 5; ++j) {
        const double ref = naive_gip(joints, k.log_params(), X1.row(i), X2.row(j), friction);
        EXPECT_NEAR(K(i, j), ref, 1e-12 * std::max(1.0, std::abs(ref)));
      }
    // Diagonal, single-row and self paths agree with cross().
    Eigen::VectorXd d;
    k.diagonal(Z1, d);
    Eigen::MatrixXd K11;
    k.cross(Z1, Z1, K11);
    EXPECT_LT((d - K11.diagonal()).norm() / K11.diagonal().norm(), 1e-13);
    KernelScratch scratch;
    Eigen::VectorXd row(Z2.rows());
    const Eigen::RowVectorXd z = Z1.row(2);
    k.row(z.data(), Z2, row, scratch);
    EXPECT_LT((row - K.row(2).transpose()).norm() / K.row(2).norm(), 1e-13);
    EXPECT_NEAR(k.self(z.data(), fm.feature_dim(), scratch), K11(2, 2), 1e-12 * std::abs(K11(2, 2)));
    // Fused lower-triangle Gram equals cross() on the lower triangle.
    Eigen::MatrixXd G(Z1.rows(), Z1.rows());
    k.gram_lower(Z1, G, scratch);
    for (int c = 0; c < Z1.rows(); ++c)
      for (int r = c; r < Z1.rows(); ++r) EXPECT_NEAR(G(r, c), K11(r, c), 1e-12 * std::abs(K11(r, c)));
  }
}

TEST_P(GipKernelTest, NamesMatchCompositeAndSayWhatTheyAre) {
  const JointTypes joints = JointTypes::parse(GetParam());
  GipKernel k(FeatureMap(joints), 0);
  const auto names = k.param_names();
  ASSERT_EQ(static_cast<int>(names.size()), k.num_params());
  EXPECT_EQ(names[0], joints.is_revolute(0) ? "joint1.cs.factor1.s0" : "joint1.p.factor1.s0");
  EXPECT_EQ(names[1], joints.is_revolute(0) ? "joint1.cs.factor1.l_cos" : "joint1.p.factor1.l_q");
  EXPECT_EQ(names.back(), "friction.l_coulomb");
  EXPECT_NE(std::find(names.begin(), names.end(), "acc.l_qdd1"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "acc.s0"), names.end());
}

TEST_P(GipKernelTest, GradientsMatchFiniteDifferencesAndComposite) {
  const JointTypes joints = JointTypes::parse(GetParam());
  const FeatureMap fm(joints);
  // More rows than one fused block (256) so block boundaries are exercised.
  const Eigen::MatrixXd Zbig = fm.compute(random_inputs(joints, 300, 14));
  const Eigen::MatrixXd Z1 = fm.compute(random_inputs(joints, 6, 15)), Z2 = fm.compute(random_inputs(joints, 5, 16));
  for (int friction : {-1, 0}) {
    GipKernel k(fm, friction);
    k.set_log_params(random_vector(k.num_params(), -1.0, 0.3, 17));
    expect_gradient_matrices_match(k, Z1, Z2, std::string("gip ") + GetParam());
    expect_contractions_match(k, Z1, std::string("gip ") + GetParam());
    // Fused contraction over several blocks vs the unfused composite kernel.
    const Eigen::Index N = Zbig.rows();
    Eigen::MatrixXd W = test::random_matrix(N, N, -1.0, 1.0, 907);
    W = (W + W.transpose()).eval();
    KernelScratch s1, s2;
    Eigen::VectorXd g = Eigen::VectorXd::Zero(k.num_params()), ref = g;
    k.contract(Zbig, W, g, s1);
    k.to_composite()->contract(Zbig, W, ref, s2);
    EXPECT_LT((g - ref).norm() / ref.norm(), 1e-10) << GetParam();
  }
}

INSTANTIATE_TEST_SUITE_P(JointStrings, GipKernelTest, ::testing::ValuesIn(kJointStrings));

TEST(GipKernel, InitializationStartsFactorsApartAndNearTargetScale) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const FeatureMap fm(joints);
  const Eigen::MatrixXd Z = fm.compute(random_inputs(joints, 200, 18));
  GipKernel k(fm);
  k.initialize(Z, 2.0);
  const Eigen::VectorXd p = k.log_params();
  EXPECT_NE(p(0), p(3));  // joint 1: factor1.s0 != factor2.s0
  Eigen::VectorXd d;
  k.diagonal(Z, d);
  EXPECT_GT(d.mean(), 0.5);
  EXPECT_LT(d.mean(), 8.0);
}

// From 1536 rows on, the Gram build's and the fused gradient pass's columns run
// in tasks on every core: the same values as the unfused composite kernel, and
// the same bits on every run (each task writes its own columns and keeps its
// own share of the gradient, added in task order).
TEST(GipKernel, ColumnTasksOnEveryCoreMatchTheCompositeAndRepeatBitForBit) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const FeatureMap fm(joints);
  const Eigen::Index N = 1600;
  const Eigen::MatrixXd Z = fm.compute(random_inputs(joints, N, 19));
  GipKernel k(fm, 0);
  k.set_log_params(random_vector(k.num_params(), -1.0, 0.3, 20));
  const std::unique_ptr<Kernel> composite = k.to_composite();
  KernelScratch scratch, composite_scratch;
  Eigen::MatrixXd G(N, N), K;
  k.gram_lower(Z, G, scratch);
  composite->cross(Z, Z, K);
  double worst = 0.0;
  for (Eigen::Index c = 0; c < N; ++c)
    for (Eigen::Index r = c; r < N; ++r) worst = std::max(worst, std::abs(G(r, c) - K(r, c)));
  EXPECT_LT(worst, 1e-12 * K.cwiseAbs().maxCoeff()) << "Gram's lower triangle against the composite's cross()";

  const Eigen::VectorXd alpha = random_vector(N, -1.0, 1.0, 21);
  Eigen::MatrixXd Kinv = test::random_matrix(N, N, -1.0, 1.0, 22);
  Kinv = (Kinv + Kinv.transpose()).eval();
  Eigen::VectorXd g = Eigen::VectorXd::Zero(k.num_params()), again = g, ref = g;
  k.contract_nll(Z, alpha, Kinv, g, scratch);
  k.contract_nll(Z, alpha, Kinv, again, scratch);
  EXPECT_TRUE((g.array() == again.array()).all()) << "a second run gave other bits";
  composite->contract(Z, alpha * alpha.transpose() - Kinv, ref, composite_scratch);
  EXPECT_LT((g - ref).norm() / ref.norm(), 1e-10);
}

TEST(KernelFactory, RejectsUnknownNames) {
  const FeatureMap fm(JointTypes::parse("RR"));
  try {
    make_kernel("matern", fm, 0);
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("gip-friction"), std::string::npos);
  }
}

TEST(JointTypes, ParsesAndRejects) {
  EXPECT_EQ(JointTypes::parse("rrPr").str(), "RRPR");
  EXPECT_EQ(JointTypes::parse("RRPR").num_prismatic(), 1);
  EXPECT_THROW(JointTypes::parse(""), std::exception);
  EXPECT_THROW(JointTypes::parse("RRXR"), std::exception);
  EXPECT_THROW(JointTypes::parse("RRRRRRRRRRRRR"), std::exception);
  EXPECT_EQ(JointTypes::parse("RRRRRRRRRRRR").size(), 12);
}

TEST(FeatureMap, LayoutFollowsMethod) {
  const FeatureMap fm(JointTypes::parse("RRPR"));
  EXPECT_EQ(fm.acceleration_group().size(), 4u + 10u);
  EXPECT_EQ(fm.position_group(2).size(), 1u);
  Eigen::MatrixXd X(1, 12);
  X << 0.3, -1.0, 0.2, 2.0, 0.5, -0.5, 1.5, 0.0, 1, 2, 3, 4;
  const Eigen::MatrixXd Z = fm.compute(X);
  EXPECT_DOUBLE_EQ(Z(0, fm.position_group(0)[0]), std::cos(0.3));
  EXPECT_DOUBLE_EQ(Z(0, fm.position_group(1)[1]), std::sin(-1.0));
  EXPECT_DOUBLE_EQ(Z(0, fm.position_group(2)[0]), 0.2);
  EXPECT_DOUBLE_EQ(Z(0, fm.acceleration_group()[0]), 1.0);  // qdd1
  EXPECT_DOUBLE_EQ(Z(0, fm.acceleration_group()[4 + 1]), 0.5 * -0.5);  // qd1 qd2
  EXPECT_DOUBLE_EQ(Z(0, fm.friction_sign(1)), -1.0);
  EXPECT_DOUBLE_EQ(Z(0, fm.friction_sign(3)), 0.0);
}

}  // namespace
}  // namespace gipdyn
