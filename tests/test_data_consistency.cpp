// neighbour_consistency: torques at revisited states, within a log and between logs.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "gipdyn/data_consistency.hpp"
#include "gipdyn/error.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

// A 2-joint log that revisits its states: each joint runs a sum of two slow
// sinusoids whose periods divide the log, sampled every 0.01 s.
struct Log {
  Eigen::MatrixXd X, tau_true;
};

Log periodic_log(int rows) {
  Log log{Eigen::MatrixXd::Zero(rows, 6), Eigen::MatrixXd(rows, 2)};
  for (int r = 0; r < rows; ++r) {
    const double t = 0.01 * r;
    for (int j = 0; j < 2; ++j) {
      const double w = 2.0 * M_PI / (5.0 + 5.0 * j);  // periods 5 s and 10 s
      log.X(r, j) = std::sin(w * t) + 0.3 * std::sin(3 * w * t + j);
      log.X(r, 2 + j) = w * std::cos(w * t) + 0.9 * w * std::cos(3 * w * t + j);
      log.X(r, 4 + j) = -w * w * std::sin(w * t) - 2.7 * w * w * std::sin(3 * w * t + j);
    }
    log.tau_true(r, 0) = 5.0 * std::cos(log.X(r, 0)) + 0.5 * log.X(r, 2);
    log.tau_true(r, 1) = 2.0 * std::sin(log.X(r, 0) + log.X(r, 1)) + 0.3 * std::tanh(log.X(r, 3) / 0.1);
  }
  return log;
}

double variance(const Eigen::VectorXd& v) { return (v.array() - v.mean()).square().mean(); }

TEST(NeighbourConsistency, WithinOneLogHalfTheNeighbourNmseIsTheNoiseShare) {
  const Log log = periodic_log(4000);  // 40 s: four and eight visits of every state
  const double sd = 0.2;
  const Eigen::MatrixXd tau = test::with_noise(log.tau_true, sd, 1);
  NeighbourConsistencyOptions o;
  o.radius = 0.02;
  const NeighbourConsistency c = neighbour_consistency(log.X, tau, o);
  ASSERT_EQ(c.status, NeighbourConsistency::Status::Ok) << c.message;
  EXPECT_GT(c.pairs, c.queries / 2);
  for (int j = 0; j < 2; ++j) {
    const double noise_share = sd * sd / variance(tau.col(j));
    EXPECT_NEAR(c.neighbour_nmse(j) / 2.0, noise_share, 0.25 * noise_share) << "joint " << j + 1;
  }
}

TEST(NeighbourConsistency, ATestLogWithAnotherTorqueFunctionStandsOut) {
  const Log log = periodic_log(4000);
  const Eigen::MatrixXd train = test::with_noise(log.tau_true, 0.05, 2);
  Eigen::MatrixXd same = test::with_noise(log.tau_true, 0.05, 3), other = same;
  other.col(1) = test::with_noise(-log.tau_true.col(1) + Eigen::VectorXd::Constant(4000, 1.0), 0.05, 4);  // another function of the state
  const NeighbourConsistency consistent = neighbour_consistency(log.X, train, log.X, same);
  const NeighbourConsistency changed = neighbour_consistency(log.X, train, log.X, other);
  ASSERT_EQ(consistent.status, NeighbourConsistency::Status::Ok);
  ASSERT_EQ(changed.status, NeighbourConsistency::Status::Ok);
  EXPECT_LT(consistent.neighbour_nmse(1), 0.05);
  EXPECT_GT(consistent.correlation(1), 0.95);
  EXPECT_GT(changed.neighbour_nmse(1), 2.0);
  EXPECT_LT(changed.correlation(1), -0.9);
  EXPECT_NEAR(changed.neighbour_nmse(0), consistent.neighbour_nmse(0), 1e-12);  // joint 1 untouched
}

// The blocked GEMM search against a plain loop over every pair, on a log
// longer than one reference block, with the time separation applied.
TEST(NeighbourConsistency, BlockedSearchMatchesAPlainLoop) {
  const int rows = 4500;
  Log log = periodic_log(rows);
  log.X = test::with_noise(log.X, 0.01, 6);  // no ties between exact revisits, which rounding would break either way
  const Eigen::MatrixXd tau = test::with_noise(log.tau_true, 0.1, 5);
  NeighbourConsistencyOptions o;
  o.radius = 0.05;
  o.min_separation_rows = 50;
  o.max_queries = 700;
  const NeighbourConsistency c = neighbour_consistency(log.X, tau, o);

  Eigen::MatrixXd Z = log.X.leftCols(4);
  for (int k = 0; k < 4; ++k) {
    const double mu = Z.col(k).mean(), sdev = std::sqrt(variance(Z.col(k)));
    Z.col(k) = (Z.col(k).array() - mu) / sdev;
  }
  long pairs = 0;
  Eigen::VectorXd squared_error = Eigen::VectorXd::Zero(2), all(700);
  for (int k = 0; k < 700; ++k) {
    const Eigen::Index i = static_cast<Eigen::Index>(std::floor(static_cast<double>(k) * rows / 700));
    all(k) = tau(i, 0);
    double best = std::numeric_limits<double>::infinity();
    Eigen::Index at = -1;
    for (Eigen::Index r = 0; r < rows; ++r) {
      if (std::abs(r - i) < 50) continue;
      const double d2 = (Z.row(r) - Z.row(i)).squaredNorm();
      if (d2 < best) best = d2, at = r;
    }
    if (best <= o.radius * o.radius) {
      ++pairs;
      squared_error += (tau.row(i) - tau.row(at)).transpose().cwiseAbs2();
    }
  }
  ASSERT_EQ(c.status, NeighbourConsistency::Status::Ok);
  EXPECT_EQ(c.queries, 700);
  EXPECT_GT(pairs, 100);
  EXPECT_EQ(c.pairs, pairs);
  EXPECT_NEAR(c.neighbour_nmse(0), squared_error(0) / pairs / variance(all), 1e-9);
}

TEST(NeighbourConsistency, ARevoluteJointOneTurnAwayIsTheSameState) {
  // The second recording runs the same motion with joint 1 one turn further
  // on (a continuous joint, unwrapped): the same states for the dynamics,
  // which see q through its sine and cosine, and the same torques.
  const Log log = periodic_log(2000);
  const Eigen::MatrixXd tau = test::with_noise(log.tau_true, 0.05, 5);
  Eigen::MatrixXd turned = log.X;
  turned.col(0).array() += 2.0 * M_PI;
  const Eigen::MatrixXd tau_turned = test::with_noise(log.tau_true, 0.05, 6);
  NeighbourConsistencyOptions o;
  o.radius = 0.05;
  const NeighbourConsistency as_logged = neighbour_consistency(log.X, tau, turned, tau_turned, o);
  EXPECT_EQ(as_logged.status, NeighbourConsistency::Status::TooFewPairs);
  o.joints = "RR";
  const NeighbourConsistency on_circle = neighbour_consistency(log.X, tau, turned, tau_turned, o);
  ASSERT_EQ(on_circle.status, NeighbourConsistency::Status::Ok) << on_circle.message;
  EXPECT_GT(on_circle.pairs, on_circle.queries * 9 / 10);
  for (int j = 0; j < 2; ++j) {
    // Independent noise on both sides: twice the noise share, plus what the radius lets differ.
    const double noise_share = 0.05 * 0.05 / variance(tau_turned.col(j));
    EXPECT_LT(on_circle.neighbour_nmse(j), 4.0 * noise_share) << "joint " << j + 1;
  }
  // As comparing the motion with itself: one turn is no distance (up to the
  // rounding of cos(q + 2 pi), which can swap two equally near neighbours).
  const NeighbourConsistency unturned = neighbour_consistency(log.X, tau, log.X, tau_turned, o);
  EXPECT_EQ(unturned.pairs, on_circle.pairs);
  for (int j = 0; j < 2; ++j)
    EXPECT_NEAR(unturned.neighbour_nmse(j), on_circle.neighbour_nmse(j), 0.02 * unturned.neighbour_nmse(j));
  // Joint types that do not fit the log are named.
  o.joints = "RRR";
  EXPECT_NE(test::error_of([&] { neighbour_consistency(log.X, tau, o); }).find("NeighbourConsistencyOptions::joints names 3"),
            std::string::npos);
  o.joints = "RX";
  EXPECT_NE(test::error_of([&] { neighbour_consistency(log.X, tau, o); }).find("NeighbourConsistencyOptions::joints"),
            std::string::npos);
}

TEST(NeighbourConsistency, NoRevisitsIsAStatusNotAnException) {
  const Log log = periodic_log(300);  // 3 s: no state is visited twice 100 rows apart
  const NeighbourConsistency c = neighbour_consistency(log.X, log.tau_true);
  EXPECT_EQ(c.status, NeighbourConsistency::Status::TooFewPairs);
  EXPECT_NE(c.message.find("radius"), std::string::npos) << c.message;
  EXPECT_TRUE(std::isnan(c.neighbour_nmse(0)));
}

TEST(NeighbourConsistency, BadInputNamesTheProblem) {
  const Log log = periodic_log(500);
  Eigen::MatrixXd nan = log.X;
  nan(7, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(test::error_of([&] { neighbour_consistency(nan, log.tau_true); }).find("NaN"), std::string::npos);
  EXPECT_NE(test::error_of([&] { neighbour_consistency(log.X.leftCols(5), log.tau_true); }).find("3 x joints"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { neighbour_consistency(log.X, log.tau_true, log.X, log.tau_true.leftCols(1)); }).find("joints"),
            std::string::npos);
  NeighbourConsistencyOptions o;
  o.radius = -1.0;
  EXPECT_NE(test::error_of([&] { neighbour_consistency(log.X, log.tau_true, o); }).find("radius"), std::string::npos);
  o = {};
  o.max_queries = 0;
  EXPECT_NE(test::error_of([&] { neighbour_consistency(log.X, log.tau_true, o); }).find("max_queries"), std::string::npos);
}

}  // namespace
}  // namespace gipdyn
