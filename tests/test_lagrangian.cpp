// The LIP kernel against an independent evaluation: the energy kernel written
// out directly, with the Lagrange operator applied by finite differences.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <random>

#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/gp/lagrangian_weight_space_nll.hpp"
#include "gipdyn/kernels/friction_kernel.hpp"
#include "gipdyn/kernels/lagrangian_kernel.hpp"
#include "gipdyn/kernels/lagrangian_weight_space.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "gipdyn/training_data.hpp"
#include "test_util.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

// The energy kernel k_T + k_V written from docs/method.md section 11, with the
// parameters read in the order of LagrangianKernel::param_names().
// On a serial chain h_ab's position kernel has only the factors of joints
// after a (a <= b).
double energy_kernel(const JointTypes& joints, const Eigen::VectorXd& log_params, const Eigen::VectorXd& q1,
                     const Eigen::VectorXd& qd1, const Eigen::VectorXd& q2, const Eigen::VectorXd& qd2,
                     bool serial_chain = false) {
  const int n = joints.size();
  const Eigen::VectorXd p = log_params.array().exp();
  int k = 0;
  Eigen::MatrixXd velocity = Eigen::MatrixXd::Zero(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) velocity(a, b) = p(k++) * qd1(a) * qd1(b) * qd2(a) * qd2(b);
  auto factor = [&](int m) {
    double f = p(k++);
    if (joints.is_revolute(m)) {
      f += p(k++) * std::cos(q1(m)) * std::cos(q2(m));
      f += p(k++) * std::sin(q1(m)) * std::sin(q2(m));
    } else {
      f += p(k++) * q1(m) * q2(m);
    }
    return f;
  };
  std::vector<double> kinetic_factor(static_cast<size_t>(n));
  for (int m = 0; m < n; ++m) kinetic_factor[static_cast<size_t>(m)] = factor(m) * factor(m);
  double kinetic = 0.0, position_v = 1.0;
  for (int a = 0; a < n; ++a) {
    double position_t = 1.0;
    for (int m = serial_chain ? a + 1 : 0; m < n; ++m) position_t *= kinetic_factor[static_cast<size_t>(m)];
    kinetic += velocity.row(a).sum() * position_t;
  }
  for (int m = 0; m < n; ++m) position_v *= factor(m);
  return kinetic + position_v;
}

// The Lagrange operator tau_i = sum_j qdd_j d2f/dqd_i dqd_j + qd_j d2f/dqd_i dq_j - df/dq_i,
// applied to f(q, qd) by differences: along (qd, qdd) in (q, qd) with step h,
// in qd with step 1 (exact: f is quadratic in qd).
template <class F>
Eigen::VectorXd lagrange_operator(const F& f, const Eigen::VectorXd& x, double h) {
  const int n = static_cast<int>(x.size() / 3);
  const Eigen::VectorXd q = x.head(n), qd = x.segment(n, n), qdd = x.tail(n);
  Eigen::VectorXd tau(n);
  for (int i = 0; i < n; ++i) {
    auto dfdqd = [&](const Eigen::VectorXd& qq, const Eigen::VectorXd& vv) {
      Eigen::VectorXd vp = vv, vm = vv;
      vp(i) += 1.0;
      vm(i) -= 1.0;
      return (f(qq, vp) - f(qq, vm)) / 2.0;
    };
    const double time_derivative = (dfdqd(q + h * qd, qd + h * qdd) - dfdqd(q - h * qd, qd - h * qdd)) / (2.0 * h);
    Eigen::VectorXd qp = q, qm = q;
    qp(i) += h;
    qm(i) -= h;
    tau(i) = time_derivative - (f(qp, qd) - f(qm, qd)) / (2.0 * h);
  }
  return tau;
}

Eigen::VectorXd random_state(int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  Eigen::VectorXd x(3 * n);
  for (int k = 0; k < 3 * n; ++k) x(k) = u(rng);
  return x;
}

// "RRPR", "RRPR+friction", "RRPR+chain" (serial chain) or "RRPR+chain+friction".
LagrangianKernel random_kernel(const std::string& spec, std::mt19937_64& rng) {
  const bool friction = spec.find("+friction") != std::string::npos;
  const bool chain = spec.find("+chain") != std::string::npos;
  LagrangianKernel k(JointTypes::parse(spec.substr(0, spec.find('+'))), friction, chain);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd p(k.num_params());
  for (Eigen::Index i = 0; i < p.size(); ++i) p(i) = u(rng);
  k.set_log_params(p);
  return k;
}

class LagrangianKernelTest : public ::testing::TestWithParam<std::string> {};

TEST_P(LagrangianKernelTest, TorqueCovarianceIsTheLagrangeOperatorOnBothArguments) {
  std::mt19937_64 rng(3);
  const LagrangianKernel k = random_kernel(GetParam(), rng);
  const JointTypes& joints = k.joints();
  const int n = joints.size();
  const Eigen::VectorXd x1 = random_state(n, rng), x2 = random_state(n, rng);
  const double h = 1e-4;
  // Column j of the block: the operator at x1 applied to the operator at x2.
  Eigen::MatrixXd numeric(n, n);
  auto inner = [&](const Eigen::VectorXd& q1, const Eigen::VectorXd& qd1) {
    return lagrange_operator(
        [&](const Eigen::VectorXd& q2, const Eigen::VectorXd& qd2) {
          return energy_kernel(joints, k.log_params(), q1, qd1, q2, qd2, k.serial_chain());
        },
        x2, h);
  };
  for (int j = 0; j < n; ++j)
    numeric.col(j) = lagrange_operator(
        [&](const Eigen::VectorXd& q1, const Eigen::VectorXd& qd1) { return inner(q1, qd1)(j); }, x1, h);
  // Friction is independent of the energies: joint m's own FrictionKernel on its velocity.
  if (k.has_friction())
    for (int m = 0; m < n; ++m) {
      FrictionKernel f(0);
      f.set_log_params(k.log_params().segment<FrictionKernel::kNumParams>(k.friction_offset() + FrictionKernel::kNumParams * m));
      Eigen::MatrixXd K;
      f.cross(Eigen::MatrixXd::Constant(1, 1, x1(n + m)), Eigen::MatrixXd::Constant(1, 1, x2(n + m)), K);
      numeric(m, m) += K(0, 0);
    }
  Eigen::MatrixXd block(n, n);
  k.torque_block(x1.data(), x2.data(), block);
  EXPECT_LT((block - numeric).cwiseAbs().maxCoeff(), 1e-5 * (1.0 + block.cwiseAbs().maxCoeff()))
      << "analytic\n" << block << "\nnumeric\n" << numeric;
}

TEST_P(LagrangianKernelTest, EnergyCovariancesAreTheOperatorOnOneArgument) {
  std::mt19937_64 rng(4);
  const LagrangianKernel k = random_kernel(GetParam(), rng);
  const JointTypes& joints = k.joints();
  const int n = joints.size();
  const Eigen::VectorXd xs = random_state(n, rng), x2 = random_state(n, rng);
  const Eigen::VectorXd q1 = xs.head(n), qd1 = xs.segment(n, n);
  // Kinetic: the energy kernel without its potential part, which does not depend on qd.
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  const Eigen::VectorXd total = lagrange_operator(
      [&](const Eigen::VectorXd& q2, const Eigen::VectorXd& qd2) {
        return energy_kernel(joints, k.log_params(), q1, qd1, q2, qd2, k.serial_chain());
      },
      x2, 1e-5);
  const Eigen::VectorXd potential = lagrange_operator(
      [&](const Eigen::VectorXd& q2, const Eigen::VectorXd& qd2) {
        return energy_kernel(joints, k.log_params(), q1, zero, q2, qd2);
      },
      x2, 1e-5);
  const Eigen::MatrixXd X2 = x2.transpose();
  const Eigen::RowVectorXd kin = k.kinetic_torque_covariance(xs.data(), X2);
  // tau = D T + dV/dq, and D applied to a function of q alone is -d/dq: so
  // cov(T, tau) = D k_T = total - potential and cov(V, tau) = dk_V/dq = -potential.
  const Eigen::RowVectorXd pot = k.potential_torque_covariance(xs.data(), X2);
  EXPECT_LT((kin.transpose() - (total - potential)).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + kin.cwiseAbs().maxCoeff()));
  EXPECT_LT((pot.transpose() + potential).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + pot.cwiseAbs().maxCoeff()));
}

TEST_P(LagrangianKernelTest, GradientMatchesFiniteDifferences) {
  std::mt19937_64 rng(5);
  LagrangianKernel k = random_kernel(GetParam(), rng);
  const int n = k.joints().size();
  const int N = 5;
  Eigen::MatrixXd X(N, 3 * n);
  for (int r = 0; r < N; ++r) X.row(r) = random_state(n, rng).transpose();
  Eigen::MatrixXd W = test::random_matrix(N * n, N * n, -1.0, 1.0, 908);
  W = (W + W.transpose()).eval();
  auto contraction = [&](const LagrangianKernel& kk) { return W.cwiseProduct(kk.torque_covariance(X, X)).sum(); };
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(k.num_params());
  Eigen::MatrixXd W_lower = W;
  W_lower.triangularView<Eigen::StrictlyUpper>().setConstant(std::nan(""));  // must not be read
  k.add_gradient(X, W_lower, grad);
  const Eigen::VectorXd p0 = k.log_params();
  const double h = 1e-4;  // 1e-6 is already dominated by rounding here
  for (int p = 0; p < k.num_params(); ++p) {
    Eigen::VectorXd pp = p0, pm = p0;
    pp(p) += h;
    pm(p) -= h;
    k.set_log_params(pp);
    const double fp = contraction(k);
    k.set_log_params(pm);
    const double fm = contraction(k);
    const double numeric = (fp - fm) / (2.0 * h);
    EXPECT_NEAR(grad(p), numeric, 1e-5 * (1.0 + std::abs(numeric))) << k.param_names()[static_cast<size_t>(p)];
  }
}

TEST_P(LagrangianKernelTest, GramIsSymmetricPositiveSemidefiniteAndMatchesItsLowerTriangleAndEachPairsBlock) {
  std::mt19937_64 rng(6);
  const LagrangianKernel k = random_kernel(GetParam(), rng);
  const int n = k.joints().size();
  const int N = 40;  // enough rows for the gram to use several chunks
  Eigen::MatrixXd X(N, 3 * n);
  for (int r = 0; r < N; ++r) X.row(r) = random_state(n, rng).transpose();
  const Eigen::MatrixXd K = k.torque_covariance(X, X);
  // The Gram reads each state's cosines and sines computed once; a single
  // pair's block (checked against the Lagrange operator above) computes its own.
  Eigen::MatrixXd block(n, n);
  for (int r = 0; r < N; r += 7)
    for (int s = 0; s < N; s += 3) {
      const Eigen::VectorXd x1 = X.row(r).transpose(), x2 = X.row(s).transpose();
      k.torque_block(x1.data(), x2.data(), block);
      EXPECT_LT((K.block(r * n, s * n, n, n) - block).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + block.cwiseAbs().maxCoeff()))
          << r << ", " << s;
    }
  EXPECT_LT((K - K.transpose()).cwiseAbs().maxCoeff(), 1e-10 * K.cwiseAbs().maxCoeff());
  Eigen::MatrixXd L;
  k.torque_gram_lower(X, L);
  EXPECT_LT((L.triangularView<Eigen::Lower>().toDenseMatrix() - K.triangularView<Eigen::Lower>().toDenseMatrix())
                .cwiseAbs()
                .maxCoeff(),
            1e-12 * K.cwiseAbs().maxCoeff());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-9 * eig.eigenvalues().maxCoeff());
}

// The weight-space mean is the same function as the kernel-space sum
// sum_r K(x, x_r) alpha_r, for any weights alpha, up to rounding.
TEST_P(LagrangianKernelTest, WeightSpaceMeanEqualsTheKernelSum) {
  std::mt19937_64 rng(11);
  const LagrangianKernel k = random_kernel(GetParam(), rng);
  const int n = k.joints().size();
  const int rows = 12;
  Eigen::MatrixXd X(rows, 3 * n), Q(5, 3 * n);
  for (int r = 0; r < rows; ++r) X.row(r) = random_state(n, rng).transpose();
  for (int r = 0; r < Q.rows(); ++r) Q.row(r) = random_state(n, rng).transpose();
  std::normal_distribution<double> normal;
  Eigen::VectorXd alpha(rows * n);
  for (Eigen::Index i = 0; i < alpha.size(); ++i) alpha(i) = normal(rng);
  const Eigen::MatrixXd K = k.torque_covariance(Q, X);
  const Eigen::VectorXd kernel_sum = K * alpha;
  const Eigen::VectorXd magnitude = K.cwiseAbs() * alpha.cwiseAbs();  // what rounding scales with
  const LagrangianWeightSpaceMean mean(k, X, alpha);
  const Eigen::MatrixXd weight = mean.mean(Q);
  LagrangianWeightSpaceMean::Workspace w(mean);
  Eigen::VectorXd single(n);
  for (int r = 0; r < Q.rows(); ++r) {
    const Eigen::VectorXd x = Q.row(r).transpose();
    mean.mean(x.data(), w, single.data());
    EXPECT_EQ(single, weight.row(r).transpose());
    for (int i = 0; i < n; ++i)
      EXPECT_NEAR(weight(r, i), kernel_sum(r * n + i), 1e-11 * magnitude(r * n + i)) << "state " << r << " joint " << i;
  }
  // A query at the workspace's previous q reuses its functions of q: the same answers as a fresh workspace,
  // for other velocities and accelerations at that q, and again after a query at another q.
  Eigen::MatrixXd same_q = Q;
  for (int r = 1; r < same_q.rows(); ++r) same_q.row(r).head(n) = Q.row(0).head(n);
  same_q.row(3) = Q.row(3);  // another q between two at the first
  const Eigen::MatrixXd fresh = mean.mean(same_q);  // every row against a state-less batch, row by row
  LagrangianWeightSpaceMean::Workspace reused(mean);
  for (int r = 0; r < same_q.rows(); ++r) {
    const Eigen::VectorXd x = same_q.row(r).transpose();
    LagrangianWeightSpaceMean::Workspace own(mean);
    Eigen::VectorXd alone(n);
    mean.mean(x.data(), own, alone.data());
    mean.mean(x.data(), reused, single.data());
    EXPECT_EQ(single, alone) << "row " << r;
    EXPECT_EQ(single, fresh.row(r).transpose()) << "row " << r;
  }
}

// The weight-space likelihood against kernel space: the NLL from the (N n)^2
// covariance and its factor, the gradient from add_gradient (itself checked
// against finite differences above) and the noise's trace term.
TEST_P(LagrangianKernelTest, WeightSpaceLikelihoodEqualsKernelSpace) {
  std::mt19937_64 rng(13);
  LagrangianKernel k = random_kernel(GetParam(), rng);
  const int n = k.joints().size();
  const int rows = 14;  // fewer than most feature counts: the formulas must not assume more torques
  Eigen::MatrixXd X(rows, 3 * n);
  for (int r = 0; r < rows; ++r) X.row(r) = random_state(n, rng).transpose();
  std::normal_distribution<double> normal;
  Eigen::VectorXd y(rows * n);
  for (Eigen::Index i = 0; i < y.size(); ++i) y(i) = normal(rng);
  if (!LagrangianWeightSpaceNll::worthwhile(k, 1000000)) {  // too many features at any size
    EXPECT_THROW(LagrangianWeightSpaceNll(k, X, y), Error);
    return;
  }
  const LagrangianWeightSpaceNll weight_space(k, X, y);
  EXPECT_EQ(static_cast<double>(weight_space.features()), LagrangianWeightSpaceNll::feature_count(k));
  EXPECT_EQ(LagrangianWeightSpaceNll::worthwhile(k, rows), weight_space.features() < rows * n);
  const int P = k.num_params();
  for (const double noise_level : {0.3, 1e-4}) {
    Eigen::VectorXd noise(n);
    for (int i = 0; i < n; ++i) noise(i) = noise_level * (1.0 + 0.5 * i);
    Eigen::MatrixXd K = k.torque_covariance(X, X);
    for (Eigen::Index r = 0; r < rows; ++r) K.diagonal().segment(r * n, n) += noise;
    const Eigen::LLT<Eigen::MatrixXd> llt(K);
    ASSERT_EQ(llt.info(), Eigen::Success);
    const Eigen::VectorXd alpha = llt.solve(y);
    const double nll = 0.5 * y.dot(alpha) + llt.matrixL().toDenseMatrix().diagonal().array().log().sum() +
                       0.5 * static_cast<double>(y.size()) * std::log(2.0 * M_PI);
    Eigen::MatrixXd W = llt.solve(Eigen::MatrixXd::Identity(K.rows(), K.cols()));
    W -= alpha * alpha.transpose();
    Eigen::VectorXd gradient = Eigen::VectorXd::Zero(P + n);
    k.add_gradient(X, W, gradient.head(P));
    gradient.head(P) *= 0.5;
    for (Eigen::Index r = 0; r < rows; ++r)
      for (int i = 0; i < n; ++i) gradient(P + i) += 0.5 * noise(i) * W(r * n + i, r * n + i);

    Eigen::VectorXd weights;
    const NllEvaluation e = weight_space.evaluate(k, noise, true, &weights);
    ASSERT_TRUE(e.ok()) << e.message;
    EXPECT_NEAR(e.nll, nll, 1e-9 * std::max(1.0, std::abs(nll))) << "noise " << noise_level;
    const double scale = gradient.cwiseAbs().maxCoeff();
    for (int p = 0; p < P + n; ++p)
      EXPECT_NEAR(e.gradient(p), gradient(p), 1e-7 * scale)
          << (p < P ? k.param_names()[static_cast<size_t>(p)] : "noise " + std::to_string(p - P)) << ", noise "
          << noise_level;
    EXPECT_LT((weights - alpha).cwiseAbs().maxCoeff(), 1e-8 * alpha.cwiseAbs().maxCoeff());
    const NllEvaluation value_only = weight_space.evaluate(k, noise, false);
    EXPECT_EQ(value_only.nll, e.nll);
    EXPECT_EQ(value_only.gradient.size(), 0);
  }
  // A noise variance far below the kernel's scale leaves A too ill-conditioned for its rounding: refused
  // (kernel space and its jitter take over), never a value.
  Eigen::VectorXd tiny = Eigen::VectorXd::Constant(n, 0.3);
  tiny(n - 1) = 1e-30;
  const NllEvaluation refused = weight_space.evaluate(k, tiny, true);
  EXPECT_EQ(refused.status, NllEvaluation::Status::NotPositiveDefinite) << refused.nll;
  EXPECT_NE(refused.message.find("kernel space"), std::string::npos) << refused.message;
  // Features belong to one structure: a kernel of other joints or without friction is refused.
  const LagrangianKernel other(JointTypes::parse(n == 1 ? "P" : std::string(static_cast<size_t>(n), 'P')),
                               k.has_friction(), k.serial_chain());
  EXPECT_THROW(weight_space.evaluate(other, Eigen::VectorXd::Ones(n), false), Error);
}

INSTANTIATE_TEST_SUITE_P(Joints, LagrangianKernelTest,
                         ::testing::Values("R", "RR", "RRPR", "RPRRRR", "R+friction", "RRPR+friction", "RR+chain",
                                           "RRPR+chain", "RPRRRR+chain", "RRPR+chain+friction"));

TEST(LagrangianKernel, InitializeGivesEachEnergyHalfTheTargetVariance) {
  LagrangianKernel k(JointTypes::parse("RRP"));
  std::mt19937_64 rng(7);
  Eigen::MatrixXd X(50, 9);
  for (int r = 0; r < 50; ++r) X.row(r) = random_state(3, rng).transpose();
  k.initialize(X, 4.0);
  const Eigen::MatrixXd K = k.torque_covariance(X.topRows(50), X.topRows(50));
  // Potential and kinetic each about 2: their sum on the diagonal averages about 4.
  EXPECT_NEAR(K.diagonal().mean(), 4.0, 0.4);
  EXPECT_THROW(k.set_log_params(Eigen::VectorXd::Zero(3)), std::exception);
}

SimulationResult small_scara(unsigned seed, int samples) {
  SimulationOptions o;
  o.samples = samples;
  o.dt = 0.1;
  o.seed = seed;
  return simulate(scara_robot(), o);
}

// The weights a final fit conditions on, (K + D)^-1 y, from weight space
// solve the system as well as a factorisation of K + D does, also where a
// joint's torque is nearly constant and its noise tiny (a SCARA's prismatic
// joint): D^-1 times the residual alone would miss y by orders of magnitude more.
TEST(LagrangianWeightSpaceNll, FinalWeightsSolveTheSystemAsWellAsAFactorisation) {
  const SimulationResult sim = small_scara(3, 300);
  const int n = 4;
  LagrangianKernel k(JointTypes::parse("RRPR"), true, true);
  k.initialize(sim.X, 1.0);
  Eigen::VectorXd y(sim.X.rows() * n);
  for (Eigen::Index r = 0; r < sim.X.rows(); ++r)
    for (int i = 0; i < n; ++i) y(r * n + i) = sim.tau(r, i);
  y /= std::sqrt(y.squaredNorm() / static_cast<double>(y.size()));
  const Eigen::VectorXd noise = Eigen::VectorXd::Constant(n, 3e-7);  // what LIP learns on such logs
  Eigen::MatrixXd C = k.torque_covariance(sim.X, sim.X);
  for (Eigen::Index r = 0; r < sim.X.rows(); ++r) C.diagonal().segment(r * n, n) += noise;
  const Eigen::LLT<Eigen::MatrixXd> llt(C);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const double factorised = (C * llt.solve(y) - y).norm();
  ASSERT_TRUE(LagrangianWeightSpaceNll::worthwhile(k, sim.X.rows()));
  Eigen::VectorXd alpha;
  const NllEvaluation e = LagrangianWeightSpaceNll(k, sim.X, y).evaluate(k, noise, false, &alpha);
  ASSERT_TRUE(e.ok()) << e.message;
  EXPECT_LT((C * alpha - y).norm(), 3.0 * factorised + 1e-14 * y.norm()) << "factorised: " << factorised;
}

TEST(LagrangianEstimator, FitsSavesAndLoadsTheSamePredictionsAndEnergies) {
  const SimulationResult train = small_scara(1, 60), test = small_scara(2, 10);
  EstimatorOptions o;
  o.name = "lip";
  o.search.optimizer.max_iterations = 30;
  const FitResult r = fit_estimator(o, train.X, train.tau, JointTypes::parse("RRPR"));
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  ASSERT_EQ(r.report.joints.size(), 4u);
  EXPECT_EQ(r.estimator->name(), "lip");
  const std::string path = ::testing::TempDir() + "/lip_roundtrip.gipdyn";
  save_estimator(*r.estimator, path);
  const auto loaded = load_estimator(path);
  ASSERT_EQ(loaded->name(), "lip");
  EXPECT_EQ(loaded->predict(test.X), r.estimator->predict(test.X));  // bit-identical
  const auto& a = dynamic_cast<const LagrangianEstimator&>(*r.estimator);
  const auto& b = dynamic_cast<const LagrangianEstimator&>(*loaded);
  EXPECT_EQ(a.kinetic_energy(test.X), b.kinetic_energy(test.X));
  EXPECT_EQ(a.potential_energy(test.X.leftCols(4)), b.potential_energy(test.X.leftCols(4)));
  // Kinetic energy is a quadratic form in the velocities: zero at rest, scales by s^2.
  Eigen::MatrixXd rest = test.X;
  rest.middleCols(4, 4).setZero();
  EXPECT_LT(a.kinetic_energy(rest).cwiseAbs().maxCoeff(), 1e-12);
  Eigen::MatrixXd doubled = test.X;
  doubled.middleCols(4, 4) *= 2.0;
  EXPECT_LT((a.kinetic_energy(doubled) - 4.0 * a.kinetic_energy(test.X)).cwiseAbs().maxCoeff(),
            1e-9 * a.kinetic_energy(test.X).cwiseAbs().maxCoeff());
  // Training is deterministic.
  const FitResult again = fit_estimator(o, train.X, train.tau, JointTypes::parse("RRPR"));
  EXPECT_EQ(again.estimator->predict(test.X), r.estimator->predict(test.X));
}

// On a serial chain (the default) the learned M_ab depends only on the joints
// after min(a, b): the first joint moves no entry, the second only row and
// column 0, and the last diagonal entry is a constant. The kernel of the LIP
// paper (serial_chain off) has no such structure. The flag survives saving,
// and a file written before it existed loads as the full kernel.
TEST(LagrangianEstimator, SerialChainInertiaIgnoresEarlierJointsAndIsSaved) {
  const SimulationResult train = small_scara(1, 60), test = small_scara(2, 6);
  const int n = 4;
  auto fit = [&](bool serial_chain) {
    EstimatorOptions o;
    o.name = "lip";
    o.search.optimizer.max_iterations = 30;
    o.serial_chain = serial_chain;
    FitResult r = fit_estimator(o, train.X, train.tau, JointTypes::parse("RRPR"));
    EXPECT_TRUE(r.report.ok()) << r.report.message;
    return r;
  };
  // Largest change of M's entries (a, b) in `entries` when joint m moves, relative to max |M|.
  auto change = [&](const Estimator& model, int m, auto entries) {
    Eigen::MatrixXd Q = test.X.leftCols(n), moved = Q;
    moved.col(m).array() += 0.7;
    const auto M = inertia(model, Q), Mm = inertia(model, moved);
    double largest = 0.0, scale = 0.0;
    for (size_t r = 0; r < M.size(); ++r) {
      scale = std::max(scale, M[r].cwiseAbs().maxCoeff());
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b)
          if (entries(a, b)) largest = std::max(largest, std::abs(Mm[r](a, b) - M[r](a, b)));
    }
    return largest / scale;
  };
  auto all = [](int, int) { return true; };
  auto beyond_row_0 = [](int a, int b) { return std::min(a, b) >= 1; };
  auto last = [&](int a, int b) { return a == n - 1 && b == n - 1; };

  const FitResult chain = fit(true), full = fit(false);
  EXPECT_LT(change(*chain.estimator, 0, all), 1e-10);
  EXPECT_LT(change(*chain.estimator, 1, beyond_row_0), 1e-10);
  EXPECT_LT(change(*chain.estimator, 2, last), 1e-10);
  EXPECT_GT(change(*chain.estimator, 1, all), 1e-6);  // row 0 does move with joint 2
  EXPECT_GT(change(*full.estimator, 0, all), 1e-6);
  EXPECT_GT(change(*full.estimator, 1, beyond_row_0), 1e-6);

  const std::string path = ::testing::TempDir() + "/lip_serial_chain.gipdyn";
  save_estimator(*chain.estimator, path);
  const auto loaded = load_estimator(path);
  EXPECT_TRUE(dynamic_cast<const LagrangianEstimator&>(*loaded).kernel().serial_chain());
  EXPECT_EQ(loaded->predict(test.X), chain.estimator->predict(test.X));
  ModelContainer old = dynamic_cast<const LagrangianEstimator&>(*full.estimator).to_container();
  old.header.erase("serial_chain");
  const LagrangianEstimator old_model = LagrangianEstimator::from_container(old, "an older file");
  EXPECT_FALSE(old_model.kernel().serial_chain());
  EXPECT_EQ(old_model.predict(test.X), full.estimator->predict(test.X));
}

// The choice of space follows the cost of a query: a 6R arm's serial-chain
// weights are a fourteenth of the full kernel's and its kernel blocks cost more,
// so its weight space pays from far fewer rows (bench/RESULTS.md, BM_LipQuery*).
TEST(LagrangianWeightSpaceMean, SerialChainPaysFromFewerRows) {
  const JointTypes arm = JointTypes::parse("RRRRRR");
  const LagrangianKernel chain(arm, false, true), full(arm, false, false);
  EXPECT_FALSE(LagrangianWeightSpaceMean::worthwhile(chain, 12));
  EXPECT_TRUE(LagrangianWeightSpaceMean::worthwhile(chain, 100));
  EXPECT_FALSE(LagrangianWeightSpaceMean::worthwhile(full, 100));
  EXPECT_TRUE(LagrangianWeightSpaceMean::worthwhile(full, 2000));
  const LagrangianKernel scara(JointTypes::parse("RRPR"), true, true);
  EXPECT_TRUE(LagrangianWeightSpaceMean::worthwhile(scara, 20));
}

// A SCARA model answers in weight space (LagrangianWeightSpaceMean), with the
// kernel-space sum's torques, through predict and through a query workspace.
TEST(LagrangianEstimator, ScaraModelAnswersInWeightSpaceWithTheKernelSumsTorques) {
  const SimulationResult train = small_scara(1, 60), test = small_scara(2, 10);
  for (const char* name : {"lip", "lip+friction"}) {
    SCOPED_TRACE(name);
    EstimatorOptions o;
    o.name = name;
    o.search.optimizer.max_iterations = 30;
    const FitResult r = fit_estimator(o, train.X, train.tau, JointTypes::parse("RRPR"));
    ASSERT_TRUE(r.report.ok()) << r.report.message;
    const auto& model = dynamic_cast<const LagrangianEstimator&>(*r.estimator);
    ASSERT_TRUE(model.queries_in_weight_space());
    const Eigen::MatrixXd K = model.kernel().torque_covariance(test.X, model.training_inputs());
    const Eigen::VectorXd kernel_sum = model.torque_scale() * (K * model.weights());
    const Eigen::VectorXd magnitude = model.torque_scale() * (K.cwiseAbs() * model.weights().cwiseAbs());
    const Eigen::MatrixXd tau = model.predict(test.X);
    auto workspace = model.make_query_workspace();
    Eigen::VectorXd one(4);
    for (Eigen::Index r2 = 0; r2 < test.X.rows(); ++r2) {
      const Eigen::VectorXd x = test.X.row(r2).transpose();
      workspace->predict(x.data(), one.data());
      EXPECT_EQ(one, tau.row(r2).transpose());
      for (int i = 0; i < 4; ++i) EXPECT_NEAR(tau(r2, i), kernel_sum(r2 * 4 + i), 1e-11 * magnitude(r2 * 4 + i));
    }
  }
}

// With friction the model keeps its name through a file, and the friction
// term stays out of the energies: the kinetic energy is still zero at rest
// and the energy estimates equal those of the same energies without it.
TEST(LagrangianEstimator, WithFrictionSavesAndLoadsAndKeepsFrictionOutOfTheEnergies) {
  SimulationOptions so;
  so.samples = 60;
  so.dt = 0.1;
  so.seed = 1;
  so.friction = true;
  const SimulationResult train = simulate(scara_robot(), so), test = small_scara(2, 10);
  EstimatorOptions o;
  o.name = "lip+friction";
  o.search.optimizer.max_iterations = 30;
  const FitResult r = fit_estimator(o, train.X, train.tau, JointTypes::parse("RRPR"));
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  ASSERT_EQ(r.estimator->name(), "lip+friction");
  const auto& a = dynamic_cast<const LagrangianEstimator&>(*r.estimator);
  ASSERT_TRUE(a.kernel().has_friction());
  EXPECT_EQ(a.kernel().param_names().back(), "friction.joint4.v_stribeck");
  const std::string path = ::testing::TempDir() + "/lip_friction_roundtrip.gipdyn";
  save_estimator(*r.estimator, path);
  const auto loaded = load_estimator(path);
  ASSERT_EQ(loaded->name(), "lip+friction");
  EXPECT_EQ(loaded->predict(test.X), r.estimator->predict(test.X));
  Eigen::MatrixXd rest = test.X;
  rest.middleCols(4, 4).setZero();
  EXPECT_LT(a.kinetic_energy(rest).cwiseAbs().maxCoeff(), 1e-12);
  // The energies' covariances with the torques do not read the friction parameters.
  LagrangianKernel without(JointTypes::parse("RRPR"), false, a.kernel().serial_chain());
  without.set_log_params(a.kernel().log_params().head(without.num_params()));
  const Eigen::MatrixXd X2 = train.X.topRows(5);
  const Eigen::VectorXd x = test.X.row(0).transpose();
  EXPECT_EQ(a.kernel().kinetic_torque_covariance(x.data(), X2), without.kinetic_torque_covariance(x.data(), X2));
  EXPECT_EQ(a.kernel().potential_torque_covariance(x.data(), X2), without.potential_torque_covariance(x.data(), X2));
}

// Hyperparameters learned on a subsample are those of a fit on the subsample
// alone; the model is then the posterior on every row, written out here as
// K*(K + noise)^-1 y from the kernel's own covariances, and so are its
// standard deviations.
TEST(LagrangianEstimator, HyperparametersFromASubsampleConditionOnEveryRow) {
  const SimulationResult train = small_scara(3, 90), test = small_scara(4, 10);
  const JointTypes joints = JointTypes::parse("RRPR");
  LagrangianOptions o;
  o.search.optimizer.max_iterations = 30;
  o.search.hyperparameter_rows = 30;
  const auto full = LagrangianEstimator::fit(train.X, train.tau, joints, o);
  ASSERT_TRUE(full.report.ok()) << full.report.message;
  const std::vector<Eigen::Index> rows = constant_step_indices(90, 30);
  o.search.hyperparameter_rows = 0;
  const auto sub = LagrangianEstimator::fit(train.X(rows, Eigen::all), train.tau(rows, Eigen::all), joints, o);
  ASSERT_TRUE(sub.report.ok()) << sub.report.message;
  const LagrangianEstimator& m = *full.estimator;
  EXPECT_EQ(m.kernel().log_params(), sub.estimator->kernel().log_params());
  EXPECT_EQ(m.noise_variances(), sub.estimator->noise_variances());
  EXPECT_EQ(m.training_inputs().rows(), 90);
  for (const JointReport& j : full.report.joints) EXPECT_EQ(j.hyperparameter_rows, 30);
  EXPECT_NE(full.report.brief_report().find("learned on 30 rows"), std::string::npos) << full.report.brief_report();

  const int n = 4;
  const double s2 = std::pow(m.to_container().header.at("torque_scale").get<double>(), 2);
  Eigen::MatrixXd K = s2 * m.kernel().torque_covariance(train.X, train.X);
  for (Eigen::Index r = 0; r < 90; ++r)
    for (int i = 0; i < n; ++i) K(r * n + i, r * n + i) += m.noise_variances()(i);
  const Eigen::MatrixXd tau_t = train.tau.transpose();
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(tau_t.data(), tau_t.size());
  const Eigen::VectorXd stacked = s2 * m.kernel().torque_covariance(test.X, train.X) * K.ldlt().solve(y);
  const Eigen::MatrixXd expected = Eigen::Map<const Eigen::MatrixXd>(stacked.data(), n, 10).transpose();
  const Eigen::MatrixXd predicted = m.predict(test.X);
  EXPECT_LT((predicted - expected).norm(), 1e-7 * expected.norm());
  // Conditioning on every row is not the subsample's model.
  EXPECT_GT((predicted - sub.estimator->predict(test.X)).norm(), 1e-6 * expected.norm());

  // Standard deviations: diag(k(x, x)) - k*' (K + noise)^-1 k*, from the same dense matrices.
  EXPECT_NE(test::error_of([&] { m.predict_std(test.X); }).find("with_variance"), std::string::npos);
  const LagrangianEstimator with_variance = m.with_variance();
  ASSERT_TRUE(with_variance.has_variance());
  const Eigen::MatrixXd sd = with_variance.predict_std(test.X);
  const Eigen::LDLT<Eigen::MatrixXd> solver(K);
  for (Eigen::Index r = 0; r < 10; ++r) {
    const Eigen::MatrixXd x = test.X.row(r);
    const Eigen::MatrixXd cross = s2 * m.kernel().torque_covariance(train.X, x);
    const Eigen::VectorXd var =
        (s2 * m.kernel().torque_covariance(x, x) - cross.transpose() * solver.solve(cross)).diagonal();
    for (int i = 0; i < n; ++i)
      EXPECT_NEAR(sd(r, i), std::sqrt(std::max(var(i), 0.0)), 1e-6 * std::sqrt(s2)) << "row " << r << " joint " << i;
  }
  EXPECT_EQ(with_variance.predict(test.X), predicted);
  // Not a clipped zero: the test states are new, so the model is uncertain about them.
  EXPECT_GT(sd.minCoeff(), 1e-4 * std::sqrt(s2));
}

// The starts (three noise levels plus the restarts) run side by side on
// SearchSettings::threads threads, and the kept optimum, every start's NLL and
// the evaluation count are those of the starts run one after another.
TEST(LagrangianEstimator, StartsRunSideBySideWithTheSequentialResult) {
  const SimulationResult train = small_scara(5, 40), test = small_scara(6, 10);
  const JointTypes joints = JointTypes::parse("RRPR");
  LagrangianOptions o;
  o.search.optimizer.max_iterations = 25;
  o.search.restarts = 2;
  auto fit_on = [&](int threads, std::set<std::thread::id>& ids, std::set<int>& restarts) {
    o.search.threads = threads;
    std::mutex mu;
    return LagrangianEstimator::fit(train.X, train.tau, joints, o, [&](const ProgressEvent& e) {
      const std::lock_guard<std::mutex> lock(mu);
      ids.insert(std::this_thread::get_id());
      restarts.insert(e.restart);
    });
  };
  std::set<std::thread::id> one_ids, four_ids;
  std::set<int> one_restarts, four_restarts;
  const auto one = fit_on(1, one_ids, one_restarts);
  const auto four = fit_on(4, four_ids, four_restarts);
  ASSERT_TRUE(one.report.ok()) << one.report.message;
  ASSERT_TRUE(four.report.ok()) << four.report.message;
  EXPECT_EQ(one_ids.size(), 1u);
  EXPECT_GE(four_ids.size(), 2u);
  EXPECT_EQ(one_restarts, (std::set<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(four_restarts, one_restarts);
  ASSERT_EQ(one.report.joints.front().restart_nlls.size(), 5u);
  EXPECT_EQ(four.report.joints.front().restart_nlls, one.report.joints.front().restart_nlls);
  EXPECT_EQ(four.report.joints.front().evaluations, one.report.joints.front().evaluations);
  EXPECT_EQ(four.estimator->kernel().log_params(), one.estimator->kernel().log_params());
  EXPECT_EQ(four.estimator->noise_variances(), one.estimator->noise_variances());
  EXPECT_EQ(four.estimator->predict(test.X), one.estimator->predict(test.X));
}

// On a subsample, the search's last iteration is followed by the one long
// step without iterations, conditioning on every row: a note says so and
// what it factorises, so that a long log's fit does not fall silent.
TEST(LagrangianEstimator, SaysWhenItConditionsOnEveryRowAfterASubsample) {
  const SimulationResult train = small_scara(5, 40);
  LagrangianOptions o;
  o.search.optimizer.max_iterations = 3;
  auto events_of = [&](int hyperparameter_rows) {
    o.search.hyperparameter_rows = hyperparameter_rows;
    std::mutex mu;
    std::vector<ProgressEvent> events;
    const auto fit = LagrangianEstimator::fit(train.X, train.tau, JointTypes::parse("RRPR"), o,
                                              [&](const ProgressEvent& e) {
                                                const std::lock_guard<std::mutex> lock(mu);
                                                events.push_back(e);
                                              });
    EXPECT_TRUE(fit.report.ok()) << fit.report.message;
    return events;
  };
  auto notes_in = [](const std::vector<ProgressEvent>& events) {
    std::vector<std::string> notes;
    for (const ProgressEvent& e : events)
      if (e.iteration == 0 && !e.finished) notes.push_back(describe(e));
    return notes;
  };
  const std::vector<ProgressEvent> subsampled = events_of(20);
  const std::vector<std::string> notes = notes_in(subsampled);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0].rfind("lip conditioning on all 40 rows with the hyperparameters found (", 0), 0u) << notes[0];
  const bool kernel_space = notes[0].find("one factorisation of a 160-square matrix") != std::string::npos;
  EXPECT_TRUE(kernel_space || notes[0].find("in weight space") != std::string::npos) << notes[0];
  EXPECT_EQ(subsampled.back().iteration, 0) << "the note comes after every iteration";
  EXPECT_TRUE(notes_in(events_of(0)).empty()) << "without a subsample the search's fit is the final one";
}

// LIP learns every joint in one optimisation: its report and warnings speak
// of that fit once, with each joint's own noise, not once per joint.
TEST(LagrangianEstimator, ReportsItsOneCoupledFitOnce) {
  const SimulationResult train = small_scara(5, 40);
  LagrangianOptions o;
  o.search.optimizer.max_iterations = 5;
  const auto fit = LagrangianEstimator::fit(train.X, train.tau, JointTypes::parse("RRPR"), o);
  ASSERT_TRUE(fit.report.ok()) << fit.report.message;
  ASSERT_EQ(fit.report.joints.size(), 4u);
  EXPECT_TRUE(one_coupled_fit(fit.report.joints));
  const std::string brief = fit.report.brief_report();
  EXPECT_NE(brief.find("\n   all  max-iter"), std::string::npos) << brief;
  for (const char* joint_row : {"\n     1  ", "\n     2  ", " joint 2 NLL over starts"})
    EXPECT_EQ(brief.find(joint_row), std::string::npos) << joint_row << "\n" << brief;
  ASSERT_EQ(fit.report.joints.front().restart_nlls.size(), 3u);
  const size_t starts = brief.find("NLL over starts");
  EXPECT_TRUE(starts != std::string::npos && brief.find("NLL over starts", starts + 1) == std::string::npos) << brief;
  char noise[32];
  std::snprintf(noise, sizeof noise, " %.2e\n", fit.report.joints.back().noise_variance);
  EXPECT_NE(brief.find(noise), std::string::npos) << brief;
  const std::vector<std::string> warnings = fit.report.warnings();
  ASSERT_FALSE(warnings.empty());
  EXPECT_EQ(warnings.front().find("the one fit of every joint stopped at the evaluation limit"), 0u) << warnings.front();
  // Per-joint fits keep their per-joint rows and warnings.
  std::vector<JointReport> separate = fit.report.joints;
  for (JointReport& j : separate) j.coupled = false;
  EXPECT_EQ(convergence_warnings(separate).front().find("joint(s) 1, 2, 3, 4 stopped"), 0u)
      << convergence_warnings(separate).front();
  // One joint's report stays a joint's row.
  FitReport single = fit.report;
  single.joints.resize(1);
  EXPECT_FALSE(one_coupled_fit(single.joints));
  EXPECT_NE(single.brief_report().find("\n     1  max-iter"), std::string::npos) << single.brief_report();
}

// Screening: every start runs start_screening_evaluations; then only the one
// with the lowest NLL so far goes on, on its own undisturbed path (the same
// L-BFGS run as without screening), and the others stop there. The choice
// does not depend on the threads.
TEST(LagrangianEstimator, ScreenedStartsContinueOnlyTheLeaderOnItsOwnPath) {
  const SimulationResult train = small_scara(5, 40);
  const JointTypes joints = JointTypes::parse("RRPR");
  constexpr int kBudget = 10;
  LagrangianOptions o;
  o.search.optimizer.max_iterations = 400;
  o.search.restarts = 2;
  struct Run {
    LagrangianEstimator::FitOutcome fit;
    std::map<int, int> last_iteration;
    std::map<int, double> best_within_budget;
  };
  auto fit_with = [&](int screening, int threads) {
    o.search.start_screening_evaluations = screening;
    o.search.threads = threads;
    Run run;
    std::mutex mu;
    run.fit = LagrangianEstimator::fit(train.X, train.tau, joints, o, [&](const ProgressEvent& e) {
      const std::lock_guard<std::mutex> lock(mu);
      if (e.iteration <= 0) return;
      run.last_iteration[e.restart] = std::max(run.last_iteration[e.restart], e.iteration);
      if (e.iteration <= kBudget) {
        auto [it, fresh] = run.best_within_budget.emplace(e.restart, e.objective);
        if (!fresh) it->second = std::min(it->second, e.objective);
      }
    });
    return run;
  };
  const Run full = fit_with(0, 0), screened = fit_with(kBudget, 0), one_thread = fit_with(kBudget, 1);
  ASSERT_TRUE(full.fit.report.ok()) << full.fit.report.message;
  ASSERT_TRUE(screened.fit.report.ok()) << screened.fit.report.message;
  const JointReport &f = full.fit.report.joints.front(), &s = screened.fit.report.joints.front();
  ASSERT_EQ(full.best_within_budget.size(), 5u);
  const int leader = std::min_element(full.best_within_budget.begin(), full.best_within_budget.end(),
                                      [](const auto& a, const auto& b) { return a.second < b.second; })
                         ->first;
  ASSERT_GT(full.last_iteration.at(leader), kBudget) << "the leader must have work left after the budget";
  for (const auto& [restart, iteration] : screened.last_iteration)
    if (restart == leader)
      EXPECT_EQ(iteration, full.last_iteration.at(leader));
    else
      EXPECT_LE(iteration, kBudget) << "start " << restart;
  EXPECT_EQ(s.restart_nlls[static_cast<size_t>(leader)], f.restart_nlls[static_cast<size_t>(leader)]);
  EXPECT_EQ(*std::min_element(s.restart_nlls.begin(), s.restart_nlls.end()), s.restart_nlls[static_cast<size_t>(leader)]);
  EXPECT_EQ(s.status, OptimizerResult::Status::Converged);
  EXPECT_EQ(s.screening_evaluations, kBudget);
  EXPECT_EQ(f.screening_evaluations, 0);
  EXPECT_NE(screened.fit.report.brief_report().find("stopped after 10 evaluations"), std::string::npos)
      << screened.fit.report.brief_report();
  EXPECT_LT(s.evaluations, f.evaluations);
  EXPECT_EQ(one_thread.fit.report.joints.front().restart_nlls, s.restart_nlls);
  EXPECT_EQ(one_thread.fit.report.joints.front().evaluations, s.evaluations);
}

// A warm start runs every start on a constant-step subsample of the
// hyperparameter rows, then only the best of them on the rows themselves, and
// lands where the search on all of them from the start does: the same NLL to
// a fraction of a nat and the same predictions, on any number of threads.
// A subsample with too few torques per hyperparameter is not used: on 40 of
// these rows the search ends 30 nats above the cold one, in another basin.
TEST(LagrangianEstimator, AWarmStartSearchesTheSubsampleFirstAndEndsWhereTheFullSearchDoes) {
  const SimulationResult train = small_scara(7, 300), test = small_scara(8, 20);
  const JointTypes joints = JointTypes::parse("RRPR");
  LagrangianOptions o;
  std::set<long> rows_seen;
  std::mutex mu;
  auto fit = [&](int warm_rows, int threads) {
    o.warm_start_rows = warm_rows;
    o.search.threads = threads;
    return LagrangianEstimator::fit(train.X, train.tau, joints, o, [&](const ProgressEvent& e) {
      const std::lock_guard<std::mutex> lock(mu);
      if (e.iteration > 0) rows_seen.insert(e.rows);
    });
  };
  const auto cold = fit(0, 0);
  ASSERT_TRUE(cold.report.ok()) << cold.report.message;
  EXPECT_EQ(rows_seen, (std::set<long>{300}));
  rows_seen.clear();
  const auto warm = fit(150, 0), warm_one_thread = fit(150, 1);
  ASSERT_TRUE(warm.report.ok()) << warm.report.message;
  EXPECT_EQ(rows_seen, (std::set<long>{150, 300}));
  const JointReport &c = cold.report.joints.front(), &w = warm.report.joints.front();
  EXPECT_GT(w.warm_start_evaluations, 0);
  EXPECT_GT(w.evaluations, 0);
  EXPECT_LT(w.evaluations, c.evaluations) << "the continuation starts near its optimum";
  EXPECT_EQ(w.restart_nlls.size(), c.restart_nlls.size());
  EXPECT_NE(warm.report.brief_report().find("warm-start subsample"), std::string::npos) << warm.report.brief_report();
  EXPECT_NEAR(w.nll, c.nll, 1.0);
  const Eigen::MatrixXd expected = cold.estimator->predict(test.X);
  EXPECT_LT((warm.estimator->predict(test.X) - expected).norm(), 0.05 * expected.norm());
  EXPECT_EQ(warm_one_thread.estimator->kernel().log_params(), warm.estimator->kernel().log_params());
  EXPECT_EQ(warm_one_thread.report.joints.front().evaluations, w.evaluations);
  // Too few rows to halve, or too few torques per hyperparameter (40 rows of
  // 4 joints for a SCARA's 47): the search runs on all of them from the start.
  for (int rows : {151, 40}) {
    const auto cold_again = fit(rows, 0);
    EXPECT_EQ(cold_again.report.joints.front().warm_start_evaluations, 0) << rows;
    EXPECT_EQ(cold_again.estimator->kernel().log_params(), cold.estimator->kernel().log_params()) << rows;
  }
}

TEST(LagrangianEstimator, RefusesOptionsItCannotHonourAndBadInput) {
  const SimulationResult train = small_scara(1, 20);
  const JointTypes joints = JointTypes::parse("RRPR");
  LagrangianOptions o;
  o.search.restarts = -1;
  EXPECT_NE(test::error_of([&] { LagrangianEstimator::fit(train.X, train.tau, joints, o); }).find("SearchSettings::restarts"),
            std::string::npos);
  o = LagrangianOptions();
  o.warm_start_rows = 3;
  EXPECT_NE(test::error_of([&] { LagrangianEstimator::fit(train.X, train.tau, joints, o); })
                .find("LagrangianOptions::warm_start_rows must be 0 or at least"),
            std::string::npos);
  // The per-joint GPs' settings that would change the model are refused, not ignored.
  for (const auto& [set, field] : std::vector<std::pair<std::function<void(EstimatorOptions&)>, std::string>>{
           {[](EstimatorOptions& e) { e.gp.mean = MeanKind::Constant; }, "GpOptions::mean"},
           {[](EstimatorOptions& e) { e.gp.prior.enabled = true; }, "GpOptions::prior"},
           {[](EstimatorOptions& e) { e.sparse.inducing_points = 10; }, "SparseOptions::inducing_points"}}) {
    EstimatorOptions e;
    e.name = "lip";
    set(e);
    EXPECT_NE(test::error_of([&] { fit_estimator(e, train.X, train.tau, joints); }).find(field), std::string::npos)
        << field;
  }
  o = LagrangianOptions();
  Eigen::MatrixXd bad = train.X;
  bad(3, 2) = std::nan("");
  EXPECT_FALSE(test::error_of([&] { LagrangianEstimator::fit(bad, train.tau, joints, o); }).empty());
  o.search.optimizer.max_iterations = 5;
  const auto fitted = LagrangianEstimator::fit(train.X, train.tau, joints, o);
  ASSERT_TRUE(fitted.report.ok());
  EXPECT_NE(test::error_of([&] { fitted.estimator->predict(train.X.leftCols(6)); }).find("12 expected"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { fitted.estimator->kinetic_energy(train.X.leftCols(4)); }).find("at least 8"),
            std::string::npos);
  // A truncated model file is refused with the file named.
  const std::string path = ::testing::TempDir() + "/lip_truncated.gipdyn";
  save_estimator(*fitted.estimator, path);
  std::string bytes = read_model_bytes(path);
  bytes.resize(bytes.size() / 2);
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
  }
  EXPECT_NE(test::error_of([&] { load_estimator(path); }).find("lip_truncated.gipdyn"), std::string::npos);
}

}  // namespace
}  // namespace gipdyn
