// Online learning: a model updated with new samples (hyperparameters fixed)
// must equal the exact GP refitted from scratch on the same rows with the same
// hyperparameters: appending, dropping the oldest rows (sliding window), one
// sample at a time or in batches, with a prior mean.
#include <gtest/gtest.h>

#include "gipdyn/model/training.hpp"
#include "gipdyn/model/update_check.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::error_of;
using test::random_inputs;
using test::two_link_torques;

const JointTypes kJoints = JointTypes::parse("RR");

Eigen::MatrixXd noisy_torques(const Eigen::MatrixXd& X, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 0.01);
  Eigen::MatrixXd Y = two_link_torques(X);
  for (Eigen::Index k = 0; k < Y.size(); ++k) Y.data()[k] += n(rng);
  return Y;
}

InverseDynamicsModel trained(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, MeanKind mean = MeanKind::Zero) {
  TrainOptions o;
  o.search.optimizer.max_iterations = 60;
  o.search.threads = 1;
  o.gp.mean = mean;
  TrainResult r = train_model(X, Y, kJoints, o);
  EXPECT_TRUE(r.report.ok()) << r.report.message;
  return std::move(r.model);
}

// The exact GP on (X, Y) with `model`'s hyperparameters, means and scaling.
InverseDynamicsModel refit_from_scratch(const InverseDynamicsModel& model, const Eigen::MatrixXd& X,
                                        const Eigen::MatrixXd& Y) {
  const Eigen::MatrixXd Z = model.features().compute(X);
  std::vector<GpRegressor> gps;
  std::vector<MeanFunction> means;
  GpWorkspace ws;
  for (int j = 0; j < 2; ++j) {
    const MeanFunction& mean = model.joint_mean(j);
    Eigen::VectorXd y = ((Y.col(j).array() - model.output_offset()(j)) / model.output_scale()(j)).matrix();
    y -= mean.evaluate(X);
    GpRegressor gp = model.joint_gp(j);
    EXPECT_TRUE(gp.fit(Z, y, true, ws).ok());
    gps.push_back(std::move(gp));
    means.push_back(mean);
  }
  return InverseDynamicsModel(kJoints, model.kernel_name(), X, std::move(gps), model.output_scaling(),
                              model.output_offset(), model.output_scale(), model.robot_prior(), std::move(means));
}

void expect_same_predictions(const InverseDynamicsModel& a, const InverseDynamicsModel& b) {
  ASSERT_EQ(a.num_training_samples(), b.num_training_samples());
  const Eigen::MatrixXd Xq = random_inputs(kJoints, 50, 99);
  Eigen::MatrixXd ma, sa, mb, sb;
  a.predict(Xq, ma, &sa);
  b.predict(Xq, mb, &sb);
  // The noise variance is small, so K is ill-conditioned and the order of the
  // arithmetic (one factorisation vs a chain of updates) shows in the last
  // digits; a wrong update would be off by the size of the torques.
  const double scale = 1.0 + mb.cwiseAbs().maxCoeff();
  EXPECT_LT((ma - mb).cwiseAbs().maxCoeff(), 1e-5 * scale);
  const Eigen::MatrixXd va = sa.cwiseAbs2(), vb = sb.cwiseAbs2();
  EXPECT_LT((va - vb).cwiseAbs().maxCoeff(), 1e-6 * scale * scale);
  for (int j = 0; j < 2; ++j) EXPECT_NEAR(a.joint_gp(j).nll(), b.joint_gp(j).nll(), 1e-4 * (1.0 + std::abs(b.joint_gp(j).nll())));
}

struct Stream {
  Eigen::MatrixXd X, Y;
};
Stream stream(int rows, unsigned seed) {
  const Eigen::MatrixXd X = random_inputs(kJoints, rows, seed);
  return {X, noisy_torques(X, seed + 1)};
}

TEST(OnlineUpdate, AppendingEqualsTheExactGpOnAllRows) {
  const Stream s = stream(140, 1);
  const InverseDynamicsModel base = trained(s.X.topRows(100), s.Y.topRows(100));
  const InverseDynamicsModel updated = base.updated(s.X.bottomRows(40), s.Y.bottomRows(40));
  EXPECT_EQ(updated.num_training_samples(), 140);
  expect_same_predictions(updated, refit_from_scratch(base, s.X, s.Y));
  // The hyperparameters did not move.
  for (int j = 0; j < 2; ++j) EXPECT_EQ(updated.joint_gp(j).kernel().log_params(), base.joint_gp(j).kernel().log_params());
}

TEST(OnlineUpdate, SlidingWindowKeepsTheNewestRows) {
  const Stream s = stream(130, 2);
  const InverseDynamicsModel base = trained(s.X.topRows(100), s.Y.topRows(100));
  const InverseDynamicsModel updated = base.updated(s.X.bottomRows(30), s.Y.bottomRows(30), 100);
  EXPECT_EQ(updated.num_training_samples(), 100);
  EXPECT_EQ(updated.training_inputs(), s.X.bottomRows(100));
  expect_same_predictions(updated, refit_from_scratch(base, s.X.bottomRows(100), s.Y.bottomRows(100)));
  // A window smaller than the batch keeps the newest rows of the batch.
  const InverseDynamicsModel tiny = base.updated(s.X.bottomRows(30), s.Y.bottomRows(30), 10);
  EXPECT_EQ(tiny.training_inputs(), s.X.bottomRows(10));
}

TEST(OnlineUpdate, OneSampleAtATimeEqualsOneBatchAndKeepsTheMean) {
  const Stream s = stream(110, 3);
  const InverseDynamicsModel base = trained(s.X.topRows(100), s.Y.topRows(100), MeanKind::Linear);
  InverseDynamicsModel m = base;
  for (int r = 100; r < 110; ++r) m = std::move(m).updated(s.X.row(r), s.Y.row(r), 105);
  EXPECT_EQ(m.num_training_samples(), 105);
  expect_same_predictions(m, refit_from_scratch(base, s.X.bottomRows(105), s.Y.bottomRows(105)));
}

TEST(OnlineUpdate, TrainingTargetsAreRecoveredFromTheFactors) {
  const Stream s = stream(80, 4);
  const InverseDynamicsModel m = trained(s.X, s.Y, MeanKind::Constant);
  EXPECT_LT((m.training_targets() - s.Y).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + s.Y.cwiseAbs().maxCoeff()));
}

// The robot picks up a payload (torques x 1.5 on a window of new rows): the
// refit starts at the old hyperparameters and can only lower the NLL on the
// kept rows; it is a fresh optimisation there, so it must match one.
TEST(OnlineUpdate, RefitStartsFromTheCurrentHyperparametersAndOnlyImproves) {
  const Stream s = stream(120, 6);
  const InverseDynamicsModel base = trained(s.X.topRows(60), s.Y.topRows(60));
  const InverseDynamicsModel moved = base.updated(s.X.bottomRows(60), 1.5 * s.Y.bottomRows(60), 60);
  TrainOptions o;
  o.search.threads = 1;
  const TrainResult refit = refit_model(moved, o);
  ASSERT_TRUE(refit.report.ok()) << refit.report.message;
  EXPECT_EQ(refit.model.num_training_samples(), 60);
  EXPECT_EQ(refit.model.kernel_name(), base.kernel_name());
  // The refit's start: the old hyperparameters' NLL on the kept rows, scaled as the refit scales them.
  for (int j = 0; j < 2; ++j) {
    GpRegressor old_gp = base.joint_gp(j);
    GpWorkspace ws;
    const Eigen::VectorXd y = ((moved.training_targets().col(j).array() - refit.model.output_offset()(j)) /
                               refit.model.output_scale()(j)).matrix();
    const NllEvaluation at_old = evaluate_nll(old_gp.kernel(), old_gp.log_noise_variance(),
                                              refit.model.training_features(), y, false, ws);
    ASSERT_TRUE(at_old.ok());
    const double after = refit.report.joints[static_cast<size_t>(j)].nll;
    EXPECT_LE(after, at_old.nll + 1e-6 * std::abs(at_old.nll)) << "joint " << j + 1;
    EXPECT_NE(refit.model.joint_gp(j).kernel().log_params(), base.joint_gp(j).kernel().log_params());
  }
  // Its predictions follow the new rows: the payload's torques.
  const Eigen::MatrixXd Xq = s.X.bottomRows(20);
  const double err = (refit.model.predict(Xq) - 1.5 * two_link_torques(Xq)).squaredNorm();
  const double err_base = (base.predict(Xq) - 1.5 * two_link_torques(Xq)).squaredNorm();
  EXPECT_LT(err, 0.01 * err_base);
  TrainOptions sparse_options;
  sparse_options.sparse.inducing_points = 20;
  sparse_options.search.threads = 1;
  const TrainResult sparse = train_model(s.X, s.Y, kJoints, sparse_options);
  ASSERT_TRUE(sparse.report.ok());
  EXPECT_NE(error_of([&] { refit_model(sparse.model, o); }).find("sparse"), std::string::npos);
  o.gp.initial_log_params = {Eigen::VectorXd::Zero(3), Eigen::VectorXd::Zero(3)};
  EXPECT_NE(error_of([&] { train_model(s.X, s.Y, kJoints, o); }).find("GpOptions::initial_log_params of joint 1 needs"),
            std::string::npos);
}

TEST(OnlineUpdate, BadNewSamplesAreNamed) {
  const Stream s = stream(60, 5);
  const InverseDynamicsModel m = trained(s.X.topRows(50), s.Y.topRows(50));
  EXPECT_NE(error_of([&] { m.updated(s.X.bottomRows(10).leftCols(5), s.Y.bottomRows(10)); }).find("6 input and 2 torque"),
            std::string::npos);
  EXPECT_NE(error_of([&] { m.updated(s.X.bottomRows(10), s.Y.bottomRows(9)); }).find("10 input rows but 9"),
            std::string::npos);
  Eigen::MatrixXd bad = s.X.bottomRows(10);
  bad(3, 2) = std::nan("");
  EXPECT_NE(error_of([&] { m.updated(bad, s.Y.bottomRows(10)); }).find("NaN"), std::string::npos);
  // A corrupted sample used to surface as "the kernel matrix with the new rows is not finite".
  bad(3, 2) = 1e100;
  EXPECT_NE(error_of([&] { m.updated(bad, s.Y.bottomRows(10)); })
                .find("new sample input qd1 holds 1e+100 (row 4): no joint position (rad, m), velocity or acceleration"),
            std::string::npos);
  EXPECT_NE(error_of([&] { m.updated(s.X.bottomRows(10), s.Y.bottomRows(10), 2); }).find("window"), std::string::npos);
}

}  // namespace
}  // namespace gipdyn

namespace gipdyn {
namespace {

double gaussian_log_density(double residual, double variance) {
  return -0.5 * (std::log(2.0 * M_PI * variance) + residual * residual / variance);
}

}  // namespace

// The check's densities against the same GP refitted without each row, and against predictions made by hand.
TEST(UpdateCheck, OwnRowsAreLeftOutOneAtATimeAndNewRowsPredictedWithTheNoise) {
  const Stream s = stream(25, 41);
  const InverseDynamicsModel model = trained(s.X, s.Y, MeanKind::Constant);
  const Stream fresh = stream(7, 43);
  const UpdateCheck check = check_update(model, fresh.X, fresh.Y);
  for (int j = 0; j < 2; ++j) {
    const double scale = model.output_scale()(j);
    const double noise = std::exp(model.joint_gp(j).log_noise_variance()) * scale * scale;
    double own = 0.0;
    for (Eigen::Index i = 0; i < s.X.rows(); ++i) {
      Eigen::MatrixXd X(s.X.rows() - 1, s.X.cols()), Y(s.Y.rows() - 1, s.Y.cols());
      for (Eigen::Index r = 0, k = 0; r < s.X.rows(); ++r)
        if (r != i) {
          X.row(k) = s.X.row(r);
          Y.row(k++) = s.Y.row(r);
        }
      const InverseDynamicsModel without = refit_from_scratch(model, X, Y);
      Eigen::MatrixXd mean, sd;
      without.predict(s.X.row(i), mean, &sd);
      own += gaussian_log_density(s.Y(i, j) - mean(0, j), sd(0, j) * sd(0, j) + noise);
    }
    EXPECT_NEAR(check.own_rows_lpd(j), own / static_cast<double>(s.X.rows()), 1e-6 * (1.0 + std::abs(own)));
    Eigen::MatrixXd mean, sd;
    model.predict(fresh.X, mean, &sd);
    double fresh_lpd = 0.0;
    for (Eigen::Index r = 0; r < fresh.X.rows(); ++r)
      fresh_lpd += gaussian_log_density(fresh.Y(r, j) - mean(r, j), sd(r, j) * sd(r, j) + noise);
    EXPECT_NEAR(check.new_rows_lpd(j), fresh_lpd / 7.0, 1e-9 * (1.0 + std::abs(fresh_lpd)));
  }
}

// Rows of the same function pass; rows of another robot (twice the torques) do not, and the warning names them.
TEST(UpdateCheck, RowsOfTheSameRobotPassAndRowsTheHyperparametersDoNotFitAreNamed) {
  const Stream s = stream(60, 51);
  const InverseDynamicsModel model = trained(s.X, s.Y);
  const Stream same = stream(40, 53);
  const UpdateCheck ok = check_update(model, same.X, same.Y);
  EXPECT_TRUE(ok.passed()) << ok.brief_report();
  EXPECT_EQ(ok.warning(), "");
  Stream heavier = same;
  heavier.Y.col(1) *= 3.0;
  const UpdateCheck misfit = check_update(model, heavier.X, heavier.Y);
  EXPECT_EQ(misfit.misfit_joints(), std::vector<int>{1}) << misfit.brief_report();
  EXPECT_NE(misfit.warning().find("the new rows of joint(s) 2 are"), std::string::npos) << misfit.warning();
  EXPECT_NE(misfit.brief_report().find("joint 2:"), std::string::npos);
  EXPECT_NE(error_of([&] { check_update(model, same.X.leftCols(5), same.Y); }).find("needs new rows of 6 inputs"),
            std::string::npos);
}

}  // namespace gipdyn
