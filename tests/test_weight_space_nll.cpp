// The weight-space NLL of a finite feature expansion (PP) against the exact
// GP's NLL on the N x N kernel matrix, an independent computation of the same
// value and gradient.
#include <gtest/gtest.h>

#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/gp/weight_space_nll.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::random_inputs;
using test::random_vector;

struct Case {
  const char* joints;
  int rows;           // below the feature count too: the weight-space formula must not assume N >= r
  double noise;       // the noise variance, relative to the targets' variance of about 1/3
  bool friction;
};

class WeightSpaceNllTest : public ::testing::TestWithParam<Case> {};

TEST_P(WeightSpaceNllTest, EqualsTheExactNllAndGradient) {
  const Case c = GetParam();
  const JointTypes joints = JointTypes::parse(c.joints);
  const FeatureMap fm(joints);
  const Eigen::MatrixXd Z = fm.compute(random_inputs(joints, c.rows, 31));
  const Eigen::VectorXd y = random_vector(c.rows, -1, 1, 32);
  RobotPrior prior;
  prior.robot = std::make_shared<const RobotModel>(joints.str() == "RRPR" ? scara_robot() : ur10_robot());
  prior.friction = c.friction;
  for (int joint : {0, joints.size() - 1}) {
    auto kernel = make_kernel("pp", fm, joint, prior);
    kernel->initialize(Z, 1.0);
    const int P = kernel->num_params();
    Eigen::MatrixXd Phi;
    ASSERT_TRUE(kernel->weight_space_features(Z, Phi));
    ASSERT_EQ(Phi.cols(), P);
    const WeightSpaceNll weight_space(Phi, y);
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::VectorXd log_s = kernel->log_params() + random_vector(P, -1.0, 1.0, 40 + trial);
      kernel->set_log_params(log_s);
      GpWorkspace ws;
      const NllEvaluation exact = evaluate_nll(*kernel, std::log(c.noise), Z, y, true, ws);
      ASSERT_TRUE(exact.ok()) << exact.message;
      ASSERT_EQ(exact.jitter, 0.0);
      const NllEvaluation e = weight_space.evaluate(log_s, std::log(c.noise));
      ASSERT_TRUE(e.ok()) << e.message;
      EXPECT_NEAR(e.nll, exact.nll, 1e-9 * std::max(1.0, std::abs(exact.nll))) << c.joints << " joint " << joint;
      ASSERT_EQ(e.gradient.size(), exact.gradient.size());
      const double scale = exact.gradient.cwiseAbs().maxCoeff();
      for (Eigen::Index k = 0; k < e.gradient.size(); ++k)
        EXPECT_NEAR(e.gradient(k), exact.gradient(k), 1e-7 * scale)
            << c.joints << " joint " << joint << " parameter " << k << " of " << P;
      const NllEvaluation value_only = weight_space.evaluate(log_s, std::log(c.noise), false);
      EXPECT_EQ(value_only.nll, e.nll);
      EXPECT_EQ(value_only.gradient.size(), 0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, WeightSpaceNllTest,
                         ::testing::Values(Case{"RRPR", 120, 0.1, false}, Case{"RRPR", 120, 1e-5, false},
                                           Case{"RRPR", 25, 0.1, false}, Case{"RRRRRR", 150, 1e-3, true},
                                           Case{"RRRRRR", 40, 0.1, true}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return std::string(info.param.joints) + "_rows" + std::to_string(info.param.rows) +
                                  "_case" + std::to_string(info.index);
                         });

TEST(WeightSpaceNll, OnlyFiniteFeatureExpansionsOfferIt) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const FeatureMap fm(joints);
  const Eigen::MatrixXd Z = fm.compute(random_inputs(joints, 10, 5));
  Eigen::MatrixXd Phi(1, 1);
  for (const char* name : {"gip", "rbf", "gip+rbf"}) {
    EXPECT_FALSE(make_kernel(name, fm, 0, {})->weight_space_features(Z, Phi)) << name;
    EXPECT_EQ(Phi.size(), 1) << name;
  }
  RobotPrior prior;
  prior.robot = std::make_shared<const RobotModel>(scara_robot());
  // PP plus an RBF is no longer a finite expansion.
  EXPECT_FALSE(make_kernel("sp", fm, 0, prior)->weight_space_features(Z, Phi));
  EXPECT_THROW(WeightSpaceNll(Eigen::MatrixXd::Ones(10, 3), Eigen::VectorXd::Ones(9)), Error);
  const WeightSpaceNll w(Eigen::MatrixXd::Ones(10, 3), Eigen::VectorXd::Ones(10));
  EXPECT_THROW(w.evaluate(Eigen::VectorXd::Zero(2), 0.0), Error);
}

}  // namespace
}  // namespace gipdyn
