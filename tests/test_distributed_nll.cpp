// Distributed exact GP (MPI + ScaLAPACK), run by ctest under mpirun with 2 and
// 4 processes (a 1 x 2 and a 2 x 2 grid): the NLL, its gradient and alpha
// equal the single-process ones, the jitter fallback agrees, a distributed
// training gives the single-process model, and the processes refuse data they
// disagree on, all of them at once.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>

#include "gipdyn/distributed/distributed_nll.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/training.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::random_inputs;
using test::random_vector;

int world_size() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size;
}

struct Case {
  const char* joints;
  const char* kernel;
  int rows;
  int block;
};

class DistributedNllTest : public ::testing::TestWithParam<Case> {};

TEST_P(DistributedNllTest, EqualsTheSingleProcessNllGradientAndAlpha) {
  const Case c = GetParam();
  const JointTypes joints = JointTypes::parse(c.joints);
  const FeatureMap fm(joints);
  const Eigen::MatrixXd Z = fm.compute(random_inputs(joints, c.rows, 31));
  const Eigen::VectorXd y = random_vector(c.rows, -1, 1, 32);
  auto kernel = make_kernel(c.kernel, fm, 0);
  kernel->initialize(Z, 1.0);
  kernel->set_log_params(kernel->log_params() + random_vector(kernel->num_params(), -0.3, 0.3, 33));
  const double log_noise = std::log(0.05);

  GpWorkspace ws;
  const NllEvaluation single = evaluate_nll(*kernel, log_noise, Z, y, true, ws);
  ASSERT_TRUE(single.ok()) << single.message;
  const Eigen::VectorXd alpha_single = ws.alpha;

  DistributedNll backend(MPI_COMM_WORLD, c.block);
  EXPECT_EQ(backend.grid_rows() * backend.grid_cols(), world_size());
  Eigen::VectorXd alpha;
  const NllEvaluation dist = backend.evaluate(*kernel, log_noise, Z, y, true, &alpha, JitterPolicy{});
  ASSERT_TRUE(dist.ok()) << dist.message;
  EXPECT_NEAR(dist.nll, single.nll, 1e-8 * std::abs(single.nll));
  ASSERT_EQ(dist.gradient.size(), single.gradient.size());
  for (Eigen::Index k = 0; k < single.gradient.size(); ++k)
    EXPECT_NEAR(dist.gradient(k), single.gradient(k), 1e-8 * single.gradient.cwiseAbs().maxCoeff())
        << "parameter " << k;
  EXPECT_LT((alpha - alpha_single).norm(), 1e-8 * alpha_single.norm());
  EXPECT_EQ(dist.jitter, 0.0);

  // Without the gradient: the same NLL and alpha.
  const NllEvaluation value_only = backend.evaluate(*kernel, log_noise, Z, y, false, &alpha, JitterPolicy{});
  ASSERT_TRUE(value_only.ok());
  EXPECT_EQ(value_only.nll, dist.nll);
  EXPECT_EQ(value_only.gradient.size(), 0);
}

INSTANTIATE_TEST_SUITE_P(
    Kernels, DistributedNllTest,
    // Row counts that are not multiples of the block, blocks smaller than a
    // process's share (several blocks each) and one larger than the matrix.
    ::testing::Values(Case{"RRPR", "gip", 157, 16}, Case{"RRRRRR", "gip", 203, 32}, Case{"RRPR", "rbf", 121, 8},
                      Case{"RRPR", "gip+friction+rbf", 97, 16}, Case{"RRPR", "gip-envelope+friction", 90, 16},
                      Case{"RR", "gip", 40, 64}),
    [](const ::testing::TestParamInfo<Case>& info) {
      return test::test_name(std::string(info.param.joints) + "_" + info.param.kernel);
    });

TEST(DistributedNll, AddsTheSameJitterAsOneProcessToASingularMatrix) {
  const JointTypes joints = JointTypes::parse("RR");
  const FeatureMap fm(joints);
  Eigen::MatrixXd X = random_inputs(joints, 60, 41);
  X.bottomRows(30) = X.topRows(30);  // duplicate rows and no noise: K is singular
  const Eigen::MatrixXd Z = fm.compute(X);
  const Eigen::VectorXd y = random_vector(60, -1, 1, 42);
  auto kernel = make_kernel("rbf", fm, 0);
  kernel->initialize(Z, 1.0);
  GpWorkspace ws;
  const NllEvaluation single = evaluate_nll(*kernel, std::log(1e-300), Z, y, true, ws);
  ASSERT_TRUE(single.ok()) << single.message;
  ASSERT_GT(single.jitter, 0.0);
  DistributedNll backend(MPI_COMM_WORLD, 8);
  const NllEvaluation dist = backend.evaluate(*kernel, std::log(1e-300), Z, y, true, nullptr, JitterPolicy{});
  ASSERT_TRUE(dist.ok()) << dist.message;
  EXPECT_EQ(dist.jitter, single.jitter);
  EXPECT_NEAR(dist.nll, single.nll, 1e-6 * std::abs(single.nll));

  // A bound too small to reach: every process reports the failure, none hangs.
  JitterPolicy tight;
  tight.max_relative = 1e-30;
  const NllEvaluation fail = backend.evaluate(*kernel, std::log(1e-300), Z, y, true, nullptr, tight);
  EXPECT_EQ(fail.status, NllEvaluation::Status::NotPositiveDefinite);
  EXPECT_NE(fail.message.find("not positive definite"), std::string::npos) << fail.message;
}

// The optimiser sees values that differ from one process's in the last digits
// (ScaLAPACK's blocked factorisation sums in another order). With a noise floor
// that keeps K well conditioned it walks the same path over a short run, and
// run to convergence it reaches the same optimum to the optimiser's tolerance.
// (Without the floor the noise falls to 1e-8 of the signal, an evaluation at
// an ill-conditioned K differs in the fifth digit and the paths part.)
TEST(DistributedNll, TrainingGivesTheSingleProcessModel) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 150, 51);
  const Eigen::MatrixXd Y = test::two_link_torques(X) + 0.01 * test::random_matrix(150, 2, -1.0, 1.0, 902);
  const Eigen::MatrixXd Xt = random_inputs(joints, 50, 52);
  for (const int max_evaluations : {12, 300}) {
    const double tol = max_evaluations == 12 ? 1e-8 : 1e-4;
    TrainOptions o;
    o.gp.keep_factor = false;
    o.search.threads = 1;
    o.search.optimizer.max_iterations = max_evaluations;
    o.search.min_noise_fraction = 1e-3;
    const TrainResult single = train_model(X, Y, joints, o);
    ASSERT_TRUE(single.report.ok()) << single.report.message;
    o.nll_backend = std::make_shared<DistributedNll>(MPI_COMM_WORLD, 16);
    const TrainResult dist = train_model(X, Y, joints, o);
    ASSERT_TRUE(dist.report.ok()) << dist.report.message;
    const Eigen::MatrixXd pred_single = single.model.predict(Xt), pred_dist = dist.model.predict(Xt);
    EXPECT_LT((pred_dist - pred_single).norm(), tol * pred_single.norm()) << max_evaluations << " evaluations";
    for (int j = 0; j < 2; ++j) {
      const JointReport &s = single.report.joints[j], &d = dist.report.joints[j];
      EXPECT_NEAR(d.nll, s.nll, tol * std::abs(s.nll)) << "joint " << j + 1 << ", " << max_evaluations;
      if (max_evaluations == 12) {
        EXPECT_EQ(d.evaluations, s.evaluations);
      }
      EXPECT_EQ(d.status, s.status) << "joint " << j + 1 << ", " << max_evaluations;
    }
  }
  TrainOptions o;
  o.gp.keep_factor = false;
  o.nll_backend = std::make_shared<DistributedNll>(MPI_COMM_WORLD, 16);
  // A warm start stays in the process, the rest is collective.
  o.gp.warm_start_rows = 40;
  const TrainResult warm = train_model(X, Y, joints, o);
  ASSERT_TRUE(warm.report.ok()) << warm.report.message;
  EXPECT_GT(warm.report.joints[0].warm_start_evaluations, 0);
}

TEST(DistributedNll, EveryProcessRefusesDataTheyDisagreeOn) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const JointTypes joints = JointTypes::parse("RR");
  Eigen::MatrixXd X = random_inputs(joints, 80, 61);
  if (rank == world_size() - 1) X(17, 2) += 1e-9;  // one value on one process
  const Eigen::MatrixXd Y = test::two_link_torques(X);
  TrainOptions o;
  o.gp.keep_factor = false;
  o.nll_backend = std::make_shared<DistributedNll>(MPI_COMM_WORLD);
  const std::string error = test::error_of([&] { train_model(X, Y, joints, o); });
  EXPECT_NE(error.find("different training data"), std::string::npos) << error;
}

TEST(DistributedNll, OptionsThatCannotBeDistributedAreRefused) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 80, 71);
  const Eigen::MatrixXd Y = test::two_link_torques(X);
  TrainOptions o;
  o.nll_backend = std::make_shared<DistributedNll>(MPI_COMM_WORLD);
  EXPECT_NE(test::error_of([&] { train_model(X, Y, joints, o); }).find("GpOptions::keep_factor"),
            std::string::npos);
  o.gp.keep_factor = false;
  o.sparse.inducing_points = 20;
  EXPECT_NE(test::error_of([&] { train_model(X, Y, joints, o); }).find("SparseOptions::inducing_points"),
            std::string::npos);
}

}  // namespace
}  // namespace gipdyn

int main(int argc, char** argv) {
  gipdyn::MpiSession mpi(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  const int failed = RUN_ALL_TESTS();
  int any = failed;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return any;
}
