// Exact GP: NLL gradient against finite differences for every kernel, and the
// jitter fallback of the Cholesky factorisation.
#include <gtest/gtest.h>

#include <lapacke.h>

#include <cmath>
#include <vector>

#include "gipdyn/features.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::finite_difference;
using test::random_inputs;
using test::random_vector;

struct Case {
  const char* joints;
  const char* kernel;
};

class NllGradientTest : public ::testing::TestWithParam<Case> {};

TEST_P(NllGradientTest, MatchesFiniteDifferences) {
  const JointTypes joints = JointTypes::parse(GetParam().joints);
  const FeatureMap fm(joints);
  const Eigen::MatrixXd Z = fm.compute(random_inputs(joints, 40, 21));
  const Eigen::VectorXd y = random_vector(40, -1, 1, 22);
  // Model-based kernels get the built-in robot with these joints.
  RobotPrior prior;
  if (joints.str() == "RRPR") prior.robot = std::make_shared<const RobotModel>(scara_robot());
  if (joints.str() == "RRRRRR") prior.robot = std::make_shared<const RobotModel>(ur10_robot());
  prior.friction = joints.str() == "RRRRRR";
  auto kernel = make_kernel(GetParam().kernel, fm, joints.size() - 1, prior);
  kernel->initialize(Z, 1.0);
  const int P = kernel->num_params();
  Eigen::VectorXd x(P + 1);
  x.head(P) = kernel->log_params() + random_vector(P, -0.3, 0.3, 23);
  x(P) = std::log(0.1);

  GpWorkspace ws;
  auto nll = [&](const Eigen::VectorXd& v) {
    kernel->set_log_params(v.head(P));
    const NllEvaluation e = evaluate_nll(*kernel, v(P), Z, y, false, ws);
    EXPECT_TRUE(e.ok()) << e.message;
    EXPECT_EQ(e.jitter, 0.0);
    return e.nll;
  };
  const Eigen::VectorXd fd = finite_difference(nll, x, 1e-3);
  kernel->set_log_params(x.head(P));
  const NllEvaluation e = evaluate_nll(*kernel, x(P), Z, y, true, ws);
  ASSERT_TRUE(e.ok()) << e.message;
  EXPECT_NEAR(e.nll, nll(x), 1e-12 * std::abs(e.nll));
  const double rel = (e.gradient - fd).norm() / fd.norm();
  EXPECT_LT(rel, 1e-6) << GetParam().joints << " " << GetParam().kernel;
  for (Eigen::Index k = 0; k < fd.size(); ++k)
    EXPECT_LT(std::abs(e.gradient(k) - fd(k)), 1e-6 * fd.cwiseAbs().maxCoeff()) << "parameter " << k;
}

INSTANTIATE_TEST_SUITE_P(
    Kernels, NllGradientTest,
    ::testing::Values(Case{"R", "gip"}, Case{"P", "gip"}, Case{"RRPR", "gip"}, Case{"RRRRRR", "gip"},
                      Case{"PRPRRR", "gip"}, Case{"R", "gip-friction"}, Case{"RRPR", "gip-friction"},
                      Case{"RRRRRR", "gip-friction"}, Case{"PRPRRR", "gip-friction"}, Case{"R", "rbf"},
                      Case{"RRPR", "rbf"}, Case{"RRRRRR", "rbf"}, Case{"PRPRRR", "rbf"},
                      Case{"RRPR", "gip+rbf"}, Case{"PRPRRR", "gip+rbf"}, Case{"RRPR", "gip-friction+rbf"},
                      Case{"RRRRRR", "gip-friction+rbf"}, Case{"R", "gip+friction"}, Case{"RRPR", "gip+friction"},
                      Case{"PRPRRR", "gip+friction+rbf"}, Case{"RRPR", "gip-envelope"}, Case{"RRRRRR", "gip-envelope"},
                      Case{"RRPR", "gip-envelope+friction"},
                      Case{"RRPR", "pp"}, Case{"RRRRRR", "pp"},
                      Case{"RRPR", "sp"}, Case{"RRRRRR", "sp"}),
    [](const ::testing::TestParamInfo<Case>& info) {
      return test::test_name(std::string(info.param.joints) + "_" + info.param.kernel);
    });

// With a mean, the coefficients are profiled out by generalised least squares:
// the gradient of the profiled NLL w.r.t. the log-parameters matches finite
// differences (which see beta move with them), and beta minimises the NLL.
TEST(ProfiledMeanNll, GradientMatchesFiniteDifferencesAndBetaIsOptimal) {
  for (const auto& [kernel_name, kind] : {std::pair{"gip", MeanKind::Constant}, std::pair{"gip", MeanKind::Linear},
                                          std::pair{"gip+rbf", MeanKind::Linear}, std::pair{"rbf", MeanKind::Constant}}) {
    const JointTypes joints = JointTypes::parse("RRPR");
    const FeatureMap fm(joints);
    const Eigen::MatrixXd X = random_inputs(joints, 40, 31);
    const Eigen::MatrixXd Z = fm.compute(X);
    const Eigen::VectorXd y = (random_vector(40, -1, 1, 32).array() + 0.7 + 0.5 * X.col(5).array()).matrix();
    auto kernel = make_kernel(kernel_name, fm, 1);
    kernel->initialize(Z, 1.0);
    MeanFunction mean(kind, 3 * joints.size());
    const int P = kernel->num_params(), M = mean.num_params();
    ASSERT_EQ(M, kind == MeanKind::Linear ? 13 : 1);
    Eigen::VectorXd x(P + 1);
    x.head(P) = kernel->log_params() + random_vector(P, -0.3, 0.3, 33);
    x(P) = std::log(0.1);
    GpWorkspace ws;
    auto nll = [&](const Eigen::VectorXd& v) {
      kernel->set_log_params(v.head(P));
      const NllEvaluation e = evaluate_profiled_nll(*kernel, v(P), mean, X, Z, y, false, ws);
      EXPECT_TRUE(e.ok()) << e.message;
      return e.nll;
    };
    const Eigen::VectorXd fd = finite_difference(nll, x, 1e-3);
    kernel->set_log_params(x.head(P));
    Eigen::VectorXd beta;
    const NllEvaluation e = evaluate_profiled_nll(*kernel, x(P), mean, X, Z, y, true, ws, &beta);
    ASSERT_TRUE(e.ok()) << e.message;
    ASSERT_EQ(e.gradient.size(), P + 1);
    ASSERT_EQ(beta.size(), M);
    EXPECT_LT((e.gradient - fd).norm() / fd.norm(), 1e-6) << kernel_name << " " << to_string(kind);
    // beta is the minimiser: the zero-mean NLL of y - H beta' is higher for any other beta',
    // and its finite-difference gradient in beta vanishes at beta.
    mean.set_params(beta);
    auto nll_at = [&](const Eigen::VectorXd& b) {
      mean.set_params(b);
      return evaluate_nll(*kernel, x(P), Z, y - mean.evaluate(X), false, ws).nll;
    };
    EXPECT_NEAR(nll_at(beta), e.nll, 1e-9 * std::abs(e.nll));
    const Eigen::VectorXd g_beta = finite_difference(nll_at, beta, 1e-4);
    EXPECT_LT(g_beta.norm(), 1e-5 * (1.0 + std::abs(e.nll))) << kernel_name << " " << to_string(kind);
    for (unsigned seed = 0; seed < 3; ++seed)
      EXPECT_GT(nll_at(beta + random_vector(M, -0.1, 0.1, 40 + seed)), e.nll) << kernel_name;
    // Without a mean, the profiled NLL is the plain one.
    EXPECT_EQ(evaluate_profiled_nll(*kernel, x(P), MeanFunction(), X, Z, y, false, ws).nll,
              evaluate_nll(*kernel, x(P), Z, y, false, ws).nll);
  }
}

TEST(Cholesky, AddsJitterToASingularMatrixAndReportsIt) {
  const Eigen::VectorXd v = random_vector(30, -1, 1, 31);
  const Eigen::MatrixXd S = v * v.transpose();  // rank one: potrf fails without jitter
  Eigen::MatrixXd K = S;
  const CholeskyResult r = cholesky_with_jitter(K, [&](Eigen::MatrixXd& M) { M = S; });
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.jitter, 0.0);
  EXPECT_LE(r.jitter, 1e-4 * S.diagonal().mean() * (1 + 1e-9));
  const Eigen::MatrixXd L = K.triangularView<Eigen::Lower>();
  const Eigen::MatrixXd rebuilt = L * L.transpose();
  EXPECT_LT((rebuilt - S - r.jitter * Eigen::MatrixXd::Identity(30, 30)).norm(), 1e-10 * S.norm());
}

TEST(Cholesky, FailsWithAClearMessageBeyondTheBound) {
  Eigen::MatrixXd S = Eigen::MatrixXd::Identity(5, 5);
  S(2, 2) = -1.0;  // indefinite: no small jitter helps
  Eigen::MatrixXd K = S;
  const CholeskyResult r = cholesky_with_jitter(K, [&](Eigen::MatrixXd& M) { M = S; });
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.status, CholeskyResult::Status::NotPositiveDefinite);
  EXPECT_NE(r.message.find("not positive definite"), std::string::npos);
  Eigen::MatrixXd N = Eigen::MatrixXd::Identity(3, 3);
  N(1, 0) = std::nan("");
  const CholeskyResult rn = cholesky_with_jitter(N, [&](Eigen::MatrixXd&) {});
  EXPECT_EQ(rn.status, CholeskyResult::Status::NonFinite);
}

// A large matrix is factorised tile by tile on several threads: the factor
// is the same bit for bit on 1, 2 and 3 threads, equals LAPACK's potrf up to
// rounding (an independent factorisation of the same matrix), leaves the
// upper triangle alone, and an indefinite matrix is refused.
// A A^T / 200 + shift I with a deterministic n x 200 A: positive definite,
// its condition number set by the shift.
Eigen::MatrixXd low_rank_plus_shift(Eigen::Index n, double shift) {
  const Eigen::MatrixXd A = Eigen::MatrixXd::NullaryExpr(n, 200, [](Eigen::Index i, Eigen::Index j) {
    const double k = static_cast<double>(i * 200 + j + 1);
    return std::sin(0.37 * k) + 0.1 * std::cos(2.9 * k);
  });
  Eigen::MatrixXd S = A * A.transpose() / 200.0;
  S.diagonal().array() += shift;
  return S;
}

TEST(Cholesky, LargeMatricesGetTheSameFactorOnAnyNumberOfThreads) {
  const Eigen::Index n = 2500;  // past the tiled threshold, and not a whole number of tiles
  const Eigen::MatrixXd S = low_rank_plus_shift(n, 1e-3);
  std::vector<Eigen::MatrixXd> factors;
  for (int threads : {1, 2, 3}) {
    Eigen::MatrixXd K = S;
    ASSERT_TRUE(cholesky_in_place(K, threads));
    EXPECT_EQ(K.triangularView<Eigen::StrictlyUpper>().toDenseMatrix(),
              S.triangularView<Eigen::StrictlyUpper>().toDenseMatrix());
    factors.push_back(K.triangularView<Eigen::Lower>());
  }
  EXPECT_EQ(factors[0], factors[1]);
  EXPECT_EQ(factors[0], factors[2]);
  Eigen::MatrixXd lapack = S;
  ASSERT_EQ(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', static_cast<lapack_int>(n), lapack.data(), static_cast<lapack_int>(n)), 0);
  const Eigen::MatrixXd reference = lapack.triangularView<Eigen::Lower>();
  EXPECT_LT((factors[0] - reference).cwiseAbs().maxCoeff(), 1e-9 * reference.cwiseAbs().maxCoeff());
  EXPECT_LT((factors[0] * factors[0].transpose() - S).norm(), 1e-12 * S.norm());

  Eigen::MatrixXd indefinite = S;
  indefinite(n - 10, n - 10) = -1.0;  // in the last tile: every earlier step succeeds
  EXPECT_FALSE(cholesky_in_place(indefinite, 2));
}

// The tiled inverse (L^{-1}, then L^{-T} L^{-1}) against LAPACK's potri, the
// same bits on any thread count, the upper triangle untouched; a singular
// factor refused.
TEST(Cholesky, LargeMatricesGetTheSameInverseOnAnyNumberOfThreads) {
  const Eigen::Index n = 2500;  // past the tiled threshold, and not a whole number of tiles
  // Well conditioned: the two inverses' rounding stays far below the bound.
  const Eigen::MatrixXd S = low_rank_plus_shift(n, 1.0);
  Eigen::MatrixXd L = S;
  ASSERT_TRUE(cholesky_in_place(L, 1));
  L.triangularView<Eigen::StrictlyUpper>().setConstant(7.0);  // must stay as it is
  std::vector<Eigen::MatrixXd> inverses;
  for (int threads : {1, 2, 3}) {
    Eigen::MatrixXd K = L;
    ASSERT_TRUE(cholesky_inverse_in_place(K, threads));
    EXPECT_TRUE((K.triangularView<Eigen::StrictlyUpper>().toDenseMatrix().array() ==
                 L.triangularView<Eigen::StrictlyUpper>().toDenseMatrix().array())
                    .all());
    inverses.push_back(K.triangularView<Eigen::Lower>());
  }
  EXPECT_EQ(inverses[0], inverses[1]);
  EXPECT_EQ(inverses[0], inverses[2]);
  Eigen::MatrixXd lapack = L;
  ASSERT_EQ(LAPACKE_dpotri(LAPACK_COL_MAJOR, 'L', static_cast<lapack_int>(n), lapack.data(), static_cast<lapack_int>(n)), 0);
  const Eigen::MatrixXd reference = lapack.triangularView<Eigen::Lower>();
  EXPECT_LT((inverses[0] - reference).cwiseAbs().maxCoeff(), 1e-12 * reference.cwiseAbs().maxCoeff());
  const Eigen::MatrixXd inverse = inverses[0].selfadjointView<Eigen::Lower>();
  EXPECT_LT((inverse * S - Eigen::MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-10);

  Eigen::MatrixXd singular = L;
  singular(n - 10, n - 10) = 0.0;  // in the last tile: every earlier step succeeds
  EXPECT_FALSE(cholesky_inverse_in_place(singular, 2));
}

TEST(ExactGp, NllReportsFailureInsteadOfThrowing) {
  const JointTypes joints = JointTypes::parse("RR");
  const FeatureMap fm(joints);
  Eigen::MatrixXd X = random_inputs(joints, 10, 32);
  X.row(1) = X.row(0);  // duplicate rows, zero noise: singular
  const Eigen::MatrixXd Z = fm.compute(X);
  auto k = make_kernel("rbf", fm, 0);
  GpWorkspace ws;
  JitterPolicy none;
  none.max_relative = 0.0;
  const NllEvaluation e = evaluate_nll(*k, std::log(1e-300), Z, Eigen::VectorXd::Ones(10), true, ws, none);
  EXPECT_FALSE(e.ok());
  EXPECT_FALSE(e.message.empty());
  const NllEvaluation j = evaluate_nll(*k, std::log(1e-300), Z, Eigen::VectorXd::Ones(10), true, ws);
  EXPECT_TRUE(j.ok()) << j.message;
  EXPECT_GT(j.jitter, 0.0);
}

TEST(ExactGp, PosteriorInterpolatesWithSmallNoiseAndVarianceShrinks) {
  const JointTypes joints = JointTypes::parse("RR");
  const FeatureMap fm(joints);
  const Eigen::MatrixXd X = random_inputs(joints, 30, 33);
  const Eigen::MatrixXd Z = fm.compute(X);
  const Eigen::VectorXd y = test::two_link_torques(X).col(0);
  auto k = make_kernel("gip", fm, 0);
  k->initialize(Z, y.squaredNorm() / 30);
  GpRegressor gp(std::move(k), std::log(1e-8));
  GpWorkspace ws;
  ASSERT_TRUE(gp.fit(Z, y, true, ws).ok());
  Eigen::VectorXd mean, var;
  gp.predict_mean(Z, Z, mean);
  gp.predict_variance(Z, Z, var);
  EXPECT_LT((mean - y).norm() / y.norm(), 1e-5);
  Eigen::VectorXd prior;
  gp.kernel().diagonal(Z, prior);
  EXPECT_LT(var.maxCoeff(), 1e-3 * prior.minCoeff());
  // Single-query paths agree with the batch ones.
  KernelScratch s;
  Eigen::VectorXd krow(30), v(30);
  const Eigen::RowVectorXd z = Z.row(4);
  EXPECT_NEAR(gp.predict_mean_one(z.data(), Z, krow, s), mean(4), 1e-9 * std::abs(mean(4)) + 1e-12);
  EXPECT_NEAR(gp.predict_variance_one(z.data(), fm.feature_dim(), krow, v, s), var(4), 1e-9 * prior(4));
}

}  // namespace
}  // namespace gipdyn
