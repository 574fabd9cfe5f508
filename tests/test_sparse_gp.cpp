// Sparse GP (VFE): the bound and its gradient against finite differences, the
// exact GP it must equal when every row is an inducing row, the cross and
// diagonal contractions against gradient_matrix, and inducing-row selection.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "gipdyn/features.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/gp/sparse_gp.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::error_of;
using test::finite_difference;
using test::random_inputs;
using test::random_vector;

struct Problem {
  FeatureMap fm;
  Eigen::MatrixXd Z;
  Eigen::VectorXd y;
  std::unique_ptr<Kernel> kernel;
};

// A smooth target plus noise, so that the bound has a meaningful optimum nearby.
Problem make_problem(const char* joints_str, const char* kernel_name, int rows, unsigned seed) {
  const JointTypes joints = JointTypes::parse(joints_str);
  Problem p{FeatureMap(joints), {}, {}, nullptr};
  const Eigen::MatrixXd X = random_inputs(joints, rows, seed);
  p.Z = p.fm.compute(X);
  p.y = (X.col(0).array().sin() + 0.3 * X.col(X.cols() - 1).array()).matrix() +
        0.1 * random_vector(rows, -1, 1, seed + 1);
  RobotPrior prior;  // the model-based kernels' nominal robot: the SCARA
  if (joints.str() == "RRPR") prior.robot = std::make_shared<const RobotModel>(scara_robot());
  p.kernel = make_kernel(kernel_name, p.fm, 0, prior);
  p.kernel->initialize(p.Z, 1.0);
  return p;
}

Eigen::MatrixXd rows_of(const Eigen::MatrixXd& Z, Eigen::Index step) {
  std::vector<Eigen::Index> idx;
  for (Eigen::Index i = 0; i < Z.rows(); i += step) idx.push_back(i);
  return Z(idx, Eigen::all);
}

class VfeGradientTest : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(VfeGradientTest, MatchesFiniteDifferences) {
  Problem p = make_problem(GetParam().first, GetParam().second, 60, 31);
  const Eigen::MatrixXd Zm = rows_of(p.Z, 4);
  const int P = p.kernel->num_params();
  Eigen::VectorXd x(P + 1);
  x.head(P) = p.kernel->log_params() + random_vector(P, -0.3, 0.3, 33);
  x(P) = std::log(0.05);
  SparseGpWorkspace ws;
  auto bound = [&](const Eigen::VectorXd& v) {
    p.kernel->set_log_params(v.head(P));
    const NllEvaluation e = evaluate_vfe(*p.kernel, v(P), p.Z, p.y, Zm, false, ws);
    EXPECT_TRUE(e.ok()) << e.message;
    return e.nll;
  };
  const Eigen::VectorXd fd = finite_difference(bound, x, 1e-3);
  p.kernel->set_log_params(x.head(P));
  const NllEvaluation e = evaluate_vfe(*p.kernel, x(P), p.Z, p.y, Zm, true, ws);
  ASSERT_TRUE(e.ok()) << e.message;
  EXPECT_NEAR(e.nll, bound(x), 1e-12 * std::abs(e.nll));
  EXPECT_LT((e.gradient - fd).norm() / fd.norm(), 1e-6) << GetParam().first << " " << GetParam().second;
  for (Eigen::Index k = 0; k < fd.size(); ++k)
    EXPECT_LT(std::abs(e.gradient(k) - fd(k)), 1e-5 * fd.cwiseAbs().maxCoeff()) << "parameter " << k;
}

INSTANTIATE_TEST_SUITE_P(Kernels, VfeGradientTest,
                         ::testing::Values(std::make_pair("RR", "gip"), std::make_pair("RP", "gip-friction"),
                                           std::make_pair("RR", "rbf"), std::make_pair("RR", "gip+rbf"),
                                           std::make_pair("RR", "gip-envelope+friction")),
                         [](const auto& info) {
                           return std::string(info.param.first) + "_" + test::test_name(info.param.second);
                         });

// More rows than one block of the passes: the blocks must add up.
TEST(SparseGp, GradientIsRightAcrossRowBlocks) {
  Problem p = make_problem("R", "rbf", 2500, 41);
  const Eigen::MatrixXd Zm = rows_of(p.Z, 250);
  const int P = p.kernel->num_params();
  Eigen::VectorXd x(P + 1);
  x.head(P) = p.kernel->log_params();
  x(P) = std::log(0.02);
  SparseGpWorkspace ws;
  auto bound = [&](const Eigen::VectorXd& v) {
    p.kernel->set_log_params(v.head(P));
    return evaluate_vfe(*p.kernel, v(P), p.Z, p.y, Zm, false, ws).nll;
  };
  const Eigen::VectorXd fd = finite_difference(bound, x, 1e-3);
  p.kernel->set_log_params(x.head(P));
  const NllEvaluation e = evaluate_vfe(*p.kernel, x(P), p.Z, p.y, Zm, true, ws);
  ASSERT_TRUE(e.ok()) << e.message;
  EXPECT_LT((e.gradient - fd).norm() / fd.norm(), 1e-6);
}

// The default contractions reduce to contract(); check them against the
// per-parameter gradient matrices they avoid forming.
TEST(SparseGp, CrossAndDiagonalContractionsMatchGradientMatrices) {
  for (const char* name : {"gip", "rbf", "gip-envelope+friction", "gip+friction+rbf", "gip-friction", "pp", "sp"}) {
    const bool model_based = std::string(name) == "pp" || std::string(name) == "sp";
    Problem p = make_problem(model_based ? "RRPR" : "RP", name, 23, 51);
    const Eigen::MatrixXd Z1 = p.Z.topRows(17), Z2 = p.Z.bottomRows(6);
    const Eigen::MatrixXd W = Eigen::MatrixXd::NullaryExpr(17, 6, [](Eigen::Index i, Eigen::Index j) {
      return std::sin(1.0 + 3.0 * static_cast<double>(i) + 7.0 * static_cast<double>(j));
    });
    const Eigen::VectorXd w = random_vector(17, -1, 1, 52);
    const int P = p.kernel->num_params();
    Eigen::VectorXd cross = Eigen::VectorXd::Zero(P), diag = Eigen::VectorXd::Zero(P);
    KernelScratch scratch;
    p.kernel->contract_cross(Z1, Z2, W, cross, scratch);
    p.kernel->contract_diagonal(Z1, w, diag, scratch);
    for (int k = 0; k < P; ++k) {
      Eigen::MatrixXd dK, dD;
      p.kernel->gradient_matrix(Z1, Z2, k, dK);
      p.kernel->gradient_matrix(Z1, Z1, k, dD);
      const double scale = 1.0 + dK.cwiseAbs().maxCoeff() * W.cwiseAbs().sum();
      EXPECT_NEAR(cross(k), W.cwiseProduct(dK).sum(), 1e-10 * scale) << name << " parameter " << k;
      EXPECT_NEAR(diag(k), w.dot(dD.diagonal()), 1e-10 * (1.0 + dD.cwiseAbs().maxCoeff() * 17)) << name << " " << k;
    }
  }
}

// Every row an inducing row: Q = K, the trace term vanishes and the bound is
// the exact NLL; the posterior is the exact one.
TEST(SparseGp, EqualsTheExactGpWhenEveryRowIsInducing) {
  Problem p = make_problem("RR", "rbf", 50, 61);
  const double log_noise = std::log(0.05);
  SparseGpWorkspace sws;
  GpWorkspace ews;
  const NllEvaluation sparse = evaluate_vfe(*p.kernel, log_noise, p.Z, p.y, p.Z, false, sws);
  const NllEvaluation exact = evaluate_nll(*p.kernel, log_noise, p.Z, p.y, false, ews);
  ASSERT_TRUE(sparse.ok() && exact.ok());
  EXPECT_NEAR(sparse.nll, exact.nll, 1e-5 * std::abs(exact.nll));

  const SparsePosterior post = fit_sparse(*p.kernel, log_noise, p.Z, p.y, p.Z, sws);
  ASSERT_TRUE(post.status.ok()) << post.status.message;
  GpRegressor sgp(p.kernel->clone(), log_noise), egp(p.kernel->clone(), log_noise);
  sgp.set_sparse_state(post.alpha, post.jitter, post.objective, post.inducing_factor, post.posterior_factor);
  ASSERT_TRUE(egp.fit(p.Z, p.y, true, ews).ok());
  const Eigen::MatrixXd Zs = p.fm.compute(random_inputs(JointTypes::parse("RR"), 20, 62));
  Eigen::VectorXd ms, me, vs, ve;
  sgp.predict_mean(Zs, p.Z, ms);
  egp.predict_mean(Zs, p.Z, me);
  sgp.predict_variance(Zs, p.Z, vs);
  egp.predict_variance(Zs, p.Z, ve);
  EXPECT_LT((ms - me).cwiseAbs().maxCoeff(), 1e-5 * me.cwiseAbs().maxCoeff());
  EXPECT_LT((vs - ve).cwiseAbs().maxCoeff(), 1e-5);
  // The single-query path agrees with the batch one.
  Eigen::VectorXd krow(p.Z.rows()), v(p.Z.rows());
  KernelScratch scratch;
  const Eigen::VectorXd z0 = Zs.row(3).transpose();
  EXPECT_NEAR(sgp.predict_mean_one(z0.data(), p.Z, krow, scratch), ms(3), 1e-12);
  EXPECT_NEAR(sgp.predict_variance_one(z0.data(), static_cast<int>(Zs.cols()), krow, v, scratch), vs(3), 1e-10);
}

// Fewer inducing rows: F bounds the exact NLL from above, and the bound tightens as rows are added.
TEST(SparseGp, BoundsTheExactNllFromAboveAndTightensWithMoreInducingRows) {
  Problem p = make_problem("RR", "gip", 120, 71);
  const double log_noise = std::log(0.05);
  GpWorkspace ews;
  SparseGpWorkspace sws;
  const double exact = evaluate_nll(*p.kernel, log_noise, p.Z, p.y, false, ews).nll;
  double previous = std::numeric_limits<double>::infinity();
  for (Eigen::Index count : {5, 20, 60}) {
    const auto rows = select_inducing_rows(*p.kernel, p.Z, count);
    const NllEvaluation e = evaluate_vfe(*p.kernel, log_noise, p.Z, p.y, p.Z(rows, Eigen::all), false, sws);
    ASSERT_TRUE(e.ok()) << e.message;
    EXPECT_GE(e.nll, exact - 1e-6 * std::abs(exact)) << count;
    EXPECT_LT(e.nll, previous) << count;
    previous = e.nll;
  }
}

TEST(SparseGp, GreedySelectionIsDeterministicDistinctAndStopsAtTheFeatureSpaceRank) {
  // One revolute joint: GIP's features span 5 position monomials (cos^2 + sin^2 = 1)
  // times 3 of the acceleration group (bias, qdd, qd^2): 15 directions.
  Problem p = make_problem("R", "gip", 200, 81);
  const auto rows = select_inducing_rows(*p.kernel, p.Z, 40);
  EXPECT_EQ(rows, select_inducing_rows(*p.kernel, p.Z, 40));
  EXPECT_EQ(std::set<Eigen::Index>(rows.begin(), rows.end()).size(), rows.size());
  EXPECT_EQ(rows.size(), 15u);
  // A smooth kernel has no such rank: every requested row is found.
  Problem q = make_problem("R", "rbf", 200, 82);
  EXPECT_EQ(select_inducing_rows(*q.kernel, q.Z, 40).size(), 40u);
  EXPECT_NE(error_of([&] { select_inducing_rows(*q.kernel, q.Z, 201); }).find("between 1 and the number"),
            std::string::npos);
}

// Adding rows online, with the inducing rows and hyperparameters fixed, gives
// the batch fit on all rows: the same alpha, the same factor of A.
TEST(SparseGp, AddingRowsOnlineEqualsTheBatchFitOnAllRows) {
  Problem p = make_problem("RR", "gip", 120, 91);
  const double log_noise = std::log(0.05);
  SparseGpWorkspace ws;
  const Eigen::MatrixXd Zm = rows_of(p.Z.topRows(80), 4);  // the inducing rows come from the first rows only
  const SparsePosterior first = fit_sparse(*p.kernel, log_noise, p.Z.topRows(80), p.y.head(80), Zm, ws);
  ASSERT_TRUE(first.status.ok());
  GpRegressor gp(p.kernel->clone(), log_noise);
  gp.set_sparse_state(first.alpha, first.jitter, first.objective, first.inducing_factor, first.posterior_factor);
  ASSERT_TRUE(gp.add_rows_sparse(Zm, p.Z.middleRows(80, 1), p.y.segment(80, 1)).ok());  // one row
  ASSERT_TRUE(gp.add_rows_sparse(Zm, p.Z.bottomRows(39), p.y.tail(39)).ok());           // then a batch
  const SparsePosterior all = fit_sparse(*p.kernel, log_noise, p.Z, p.y, Zm, ws);
  ASSERT_TRUE(all.status.ok());
  EXPECT_GT((all.alpha - first.alpha).norm(), 1e-3 * all.alpha.norm());  // the new rows matter
  EXPECT_LT((gp.alpha() - all.alpha).norm(), 1e-8 * all.alpha.norm());
  const Eigen::MatrixXd La = gp.posterior_factor().triangularView<Eigen::Lower>();
  const Eigen::MatrixXd La_batch = all.posterior_factor.triangularView<Eigen::Lower>();
  EXPECT_LT((La - La_batch).norm(), 1e-8 * La_batch.norm());

  // A sparse GP keeps no rows to drop: the exact GP's update refuses it.
  EXPECT_NE(error_of([&] { gp.update(0, Zm, 0, Eigen::VectorXd::Zero(Zm.rows())); }).find("sparse"), std::string::npos);
  EXPECT_NE(error_of([&] { gp.add_rows_sparse(Zm.topRows(3), p.Z.topRows(2), p.y.head(2)); }).find("inducing rows"),
            std::string::npos);
  GpRegressor exact(p.kernel->clone(), log_noise);
  EXPECT_NE(error_of([&] { exact.add_rows_sparse(Zm, p.Z.topRows(2), p.y.head(2)); }).find("sparse"), std::string::npos);
}

// SearchSettings::hyperparameter_rows: the optimiser sees a constant-step
// subsample, the model every row. For the exact and the sparse GP: the weights
// are those of every row at the learned hyperparameters, and the learned
// hyperparameters are an optimum of the subsample's objective: the exact NLL,
// the sparse bound, or for a sparse GP asked for it (hyperparameter_objective)
// the subsample's exact NLL.
TEST(HyperparameterRows, LearnOnASubsampleAndConditionOnEveryRow) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 240, 91);
  const Eigen::MatrixXd Y = test::two_link_torques(X) + 0.05 * test::random_matrix(240, 2, -1.0, 1.0, 916);
  const std::vector<Eigen::Index> sub = constant_step_indices(240, 80);
  struct Case {
    int inducing;
    HyperparameterObjective objective;
  };
  std::vector<Eigen::VectorXd> bound_params, exact_gp_params;
  for (const Case c : {Case{0, HyperparameterObjective::SparseBound}, Case{40, HyperparameterObjective::SparseBound},
                       Case{40, HyperparameterObjective::Exact}}) {
    const std::string label = "inducing " + std::to_string(c.inducing) + " objective " + to_string(c.objective);
    TrainOptions o;
    o.search.hyperparameter_rows = 80;
    o.sparse.inducing_points = c.inducing;
    o.sparse.hyperparameter_objective = c.objective;
    o.search.min_noise_fraction = 1e-4;  // keeps the optimum away from the noise bound
    const TrainResult r = train_model(X, Y, joints, o);
    ASSERT_TRUE(r.report.ok()) << r.report.message;
    const InverseDynamicsModel& m = r.model;
    EXPECT_EQ(m.num_data_rows(), 240);
    EXPECT_NE(r.report.brief_report().find("learned on 80 rows"), std::string::npos) << r.report.brief_report();
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(r.report.joints[j].hyperparameter_rows, 80);
      const GpRegressor& gp = m.joint_gp(j);
      const Eigen::VectorXd y = (Y.col(j).array() - m.output_offset()(j)) / m.output_scale()(j);
      const Eigen::MatrixXd Z = m.features().compute(X);
      Eigen::VectorXd alpha;
      const int P = gp.kernel().num_params();
      NllEvaluation on_subsample;  // the objective the optimiser was asked to minimise, at the kept point
      bool on_subsample_is_bound = false;
      if (c.inducing == 0) {
        GpWorkspace ws;
        ASSERT_TRUE(evaluate_nll(gp.kernel(), gp.log_noise_variance(), Z, y, false, ws).ok());
        alpha = ws.alpha;
      } else {
        SparseGpWorkspace ws;
        const Eigen::MatrixXd& Zm = m.training_features();  // a sparse model keeps its inducing rows
        alpha = fit_sparse(gp.kernel(), gp.log_noise_variance(), Z, y, Zm, ws).alpha;
        if (c.objective == HyperparameterObjective::SparseBound) {
          on_subsample = evaluate_vfe(gp.kernel(), gp.log_noise_variance(), Z(sub, Eigen::all), y(sub), Zm, true, ws);
          on_subsample_is_bound = true;
          bound_params.push_back(gp.kernel().log_params());
        }
      }
      if (!on_subsample_is_bound) {  // the exact NLL of the subsample
        GpWorkspace ws;
        on_subsample = evaluate_nll(gp.kernel(), gp.log_noise_variance(), Z(sub, Eigen::all), y(sub), true, ws);
      }
      const JointReport& jr = r.report.joints[j];
      EXPECT_LT((alpha - gp.alpha()).norm(), 1e-8 * gp.alpha().norm()) << label << " joint " << j;
      // The reported gradient is the subsample objective's, so that is the one optimised.
      const Eigen::VectorXd& g = on_subsample.gradient;
      const double noise_floor = o.search.min_noise_fraction * y.squaredNorm() / static_cast<double>(y.size());
      const bool pushed_into_floor = g(P) > 0 && jr.noise_variance <= noise_floor * (1 + 1e-9);
      const double projected = std::max(g.head(P).cwiseAbs().maxCoeff(), pushed_into_floor ? 0.0 : std::abs(g(P)));
      EXPECT_NEAR(jr.grad_norm, projected, 1e-8) << label << " joint " << j;
      // A gradient the optimiser found below the tolerance (1e-5 per row) is
      // below it by an independent evaluation too. The bound's landscape may
      // stop on a relative NLL change instead; the exact NLL's must reach it.
      if (c.objective == HyperparameterObjective::Exact) {
        EXPECT_EQ(jr.status, OptimizerResult::Status::Converged) << label << " joint " << j;
        EXPECT_LE(jr.grad_norm, 80 * 1e-5) << label << " joint " << j << "\n" << r.report.brief_report();
      }
      if (jr.grad_norm <= 80 * 1e-5) {
        EXPECT_LT(on_subsample.gradient.head(P).cwiseAbs().maxCoeff(), 80 * 1e-5 * 1.01) << label << " joint " << j;
      }
      if (c.inducing == 0) exact_gp_params.push_back(gp.kernel().log_params());
      // The same objective on the same rows from the same start: the exact GP's hyperparameters.
      if (c.inducing > 0 && c.objective == HyperparameterObjective::Exact) {
        EXPECT_LT((gp.kernel().log_params() - exact_gp_params[static_cast<size_t>(j)]).cwiseAbs().maxCoeff(), 1e-9);
      }
      if (c.objective == HyperparameterObjective::Exact) {  // a different optimum from the bound's
        EXPECT_GT((gp.kernel().log_params() - bound_params[static_cast<size_t>(j)]).cwiseAbs().maxCoeff(), 1e-3);
      }
    }
  }
  TrainOptions exact_on_all_rows;
  exact_on_all_rows.sparse.inducing_points = 40;
  exact_on_all_rows.sparse.hyperparameter_objective = HyperparameterObjective::Exact;
  EXPECT_NE(error_of([&] { train_model(X, Y, joints, exact_on_all_rows); }).find("SearchSettings::hyperparameter_rows"),
            std::string::npos);
  TrainOptions bad;
  bad.search.hyperparameter_rows = 3;
  EXPECT_NE(error_of([&] { train_model(X, Y, joints, bad); }).find("SearchSettings::hyperparameter_rows"),
            std::string::npos);
}

}  // namespace
}  // namespace gipdyn
