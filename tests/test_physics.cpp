// Gravity, inertia, Coriolis and friction extracted from learned models,
// against KDL's rigid-body dynamics of the robot that generated the data.
#include <gtest/gtest.h>

#include <cmath>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "test_util.hpp"

using namespace gipdyn;
using test::error_of;

namespace {

SimulationResult scara_data(unsigned seed, int samples, double noise, bool friction) {
  SimulationOptions o;
  o.samples = samples;
  o.dt = 0.1;  // 300 samples span the motion of 3000 at 0.01 s
  o.noise_std = noise;
  o.seed = seed;
  o.friction = friction;
  return simulate(scara_robot(), o);
}

std::unique_ptr<Estimator> fit(const std::string& name, const SimulationResult& d, bool friction = false) {
  EstimatorOptions o;
  o.name = name;
  o.gp.optimizer.max_iterations = 100;
  if (estimator_needs_robot(name)) o.robot_prior = {std::make_shared<const RobotModel>(scara_robot()), friction};
  FitResult r = fit_estimator(o, d.X, d.tau, scara_robot().joint_types());
  EXPECT_TRUE(r.report.ok()) << r.report.message;
  return std::move(r.estimator);
}

struct Truth {
  Eigen::MatrixXd g, coriolis, friction;
  std::vector<Eigen::MatrixXd> M;
};

// KDL's terms at the test states' positions and velocities.
Truth kdl_terms(const Eigen::MatrixXd& Q, const Eigen::MatrixXd& QD) {
  const RobotModel robot = scara_robot();
  const int n = robot.num_joints();
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(Q.rows(), n);
  auto id = [&](const Eigen::MatrixXd& qd, const Eigen::MatrixXd& qdd, bool friction) {
    Eigen::MatrixXd X(Q.rows(), 3 * n);
    X << Q, qd, qdd;
    return inverse_dynamics(robot, X, friction);
  };
  Truth t;
  t.g = id(zero, zero, false);
  t.coriolis = id(QD, zero, false) - t.g;
  t.friction = id(QD, zero, true) - id(QD, zero, false);
  for (Eigen::Index r = 0; r < Q.rows(); ++r) {
    Eigen::MatrixXd M(n, n);
    for (int j = 0; j < n; ++j) {
      Eigen::MatrixXd qdd = Eigen::MatrixXd::Zero(1, n);
      qdd(0, j) = 1.0;
      Eigen::MatrixXd X(1, 3 * n);
      X << Q.row(r), Eigen::RowVectorXd::Zero(n), qdd;
      M.col(j) = (inverse_dynamics(robot, X, false).row(0) - t.g.row(r)).transpose();
    }
    t.M.push_back(M);
  }
  return t;
}

double mean_relative_inertia_error(const std::vector<Eigen::MatrixXd>& A, const std::vector<Eigen::MatrixXd>& B) {
  double sum = 0.0;
  for (size_t r = 0; r < A.size(); ++r) sum += (A[r] - B[r]).norm() / B[r].norm();
  return sum / static_cast<double>(A.size());
}

double relative_error(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).norm() / b.norm(); }

}  // namespace

// The rigid-body regressor is exact without model bias: fe recovers every term,
// friction included, to rounding.
TEST(Physics, FisherianEstimatorRecoversKdlsTermsIncludingFriction) {
  const SimulationResult train = scara_data(11, 300, 0.0, true), test = scara_data(12, 40, 0.0, true);
  const auto fe = fit("fe", train, true);
  const int n = 4;
  const Eigen::MatrixXd Q = test.X.leftCols(n), QD = test.X.middleCols(n, n);
  const Truth truth = kdl_terms(Q, QD);
  EXPECT_LT(relative_error(gravity(*fe, Q), truth.g), 1e-8);
  const std::vector<Eigen::MatrixXd> M = inertia(*fe, Q);
  ASSERT_EQ(M.size(), 40u);
  EXPECT_LT(mean_relative_inertia_error(M, truth.M), 1e-8);
  const VelocityTerms v = velocity_terms(*fe, Q, QD);
  EXPECT_LT(relative_error(v.coriolis, truth.coriolis), 1e-8);
  EXPECT_LT(relative_error(v.friction, truth.friction), 1e-8);
  for (const auto& m : M) {
    const InertiaDiagnostics d = diagnose_inertia(m);
    EXPECT_LT(d.asymmetry, 1e-8);
    EXPECT_GT(d.min_eigenvalue, 0.0);
  }
}

// GIP knows only the joint types, yet its prediction has the rigid-body
// structure: the extracted terms approach KDL's. 300 noisy samples and 100
// evaluations reach 4e-4 (gravity), 4e-3 (inertia) and 1.1e-2 (Coriolis); the
// bounds keep gravity and inertia within the 1 % the method promises.
TEST(Physics, GipModelGivesGravityInertiaAndCoriolisCloseToKdl) {
  const SimulationResult train = scara_data(11, 300, 0.01, false), test = scara_data(12, 40, 0.0, false);
  const auto gip = fit("gip", train);
  const int n = 4;
  const Eigen::MatrixXd Q = test.X.leftCols(n), QD = test.X.middleCols(n, n);
  const Truth truth = kdl_terms(Q, QD);
  const double g_error = relative_error(gravity(*gip, Q), truth.g);
  const double m_error = mean_relative_inertia_error(inertia(*gip, Q), truth.M);
  const VelocityTerms v = velocity_terms(*gip, Q, QD);
  const double c_error = relative_error(v.coriolis, truth.coriolis);
  std::printf("GIP relative errors: gravity %.3g, inertia %.3g, Coriolis %.3g\n", g_error, m_error, c_error);
  EXPECT_LT(g_error, 1e-3);
  EXPECT_LT(m_error, 1e-2);
  EXPECT_LT(c_error, 3e-2);
  // GIP's velocity features are products qd_j qd_k: nothing odd in qd, so no friction.
  EXPECT_LT(v.friction.cwiseAbs().maxCoeff(), 1e-9 * (1.0 + v.coriolis.cwiseAbs().maxCoeff()));
}

TEST(Physics, ModelsWithoutTheStructureAreRefused) {
  const SimulationResult train = scara_data(11, 60, 0.01, false);
  EstimatorOptions o;
  o.name = "rbf";
  o.gp.optimizer.max_iterations = 5;
  const FitResult r = fit_estimator(o, train.X, train.tau, scara_robot().joint_types());
  ASSERT_TRUE(r.report.ok());
  const Eigen::MatrixXd Q = train.X.leftCols(4);
  EXPECT_NE(error_of([&] { gravity(*r.estimator, Q); }).find("a 'rbf' model cannot give gravity"), std::string::npos);
  EXPECT_NE(error_of([&] { inertia(*r.estimator, Q); }).find("train one of: gip"), std::string::npos);
  EXPECT_FALSE(estimator_gives_physics("gip+rbf"));
  EXPECT_FALSE(estimator_gives_physics("nn"));
  EXPECT_TRUE(estimator_gives_physics("gip-friction"));
  const auto fe = fit("fe", train);
  EXPECT_NE(error_of([&] { gravity(*fe, Q.leftCols(3)); }).find("needs 4"), std::string::npos);
  EXPECT_NE(error_of([&] { velocity_terms(*fe, Q, Q.topRows(5)); }).find("one velocity per position"),
            std::string::npos);
}
