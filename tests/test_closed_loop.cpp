// Closed-loop tracking: a model's feed-forward torque in a PD loop on the true
// robot. The exact model tracks as well as the robot's own dynamics, far
// better than PD alone; a learned GIP model sits in between.
#include <gtest/gtest.h>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/closed_loop.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "scara_fit.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

SimulationResult trajectory(int samples, double dt, unsigned seed, double noise) {
  SimulationOptions o;
  o.samples = samples;
  o.dt = dt;
  o.seed = seed;
  o.noise_std = noise;
  return simulate(scara_robot(), o);
}

TEST(ClosedLoop, FeedForwardFromTheRightModelTracksAndPdAloneLags) {
  const RobotModel robot = scara_robot();
  const SimulationResult reference = trajectory(1000, 0.001, 12, 0.0);  // 1 s at 1 kHz
  TrackingOptions o;
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(1000, 4);
  const TrackingResult pd = track_reference(robot, reference.X, zero, o);
  const TrackingResult ideal = track_reference(robot, reference.X, inverse_dynamics(robot, reference.X), o);
  const SimulationResult train = trajectory(300, 0.1, 11, 0.01);
  const auto fe = test::fit_on_scara("fe", train), gip = test::fit_on_scara("gip", train);
  const TrackingResult with_fe = track_reference(robot, reference.X, fe->predict(reference.X), o);
  const TrackingResult with_gip = track_reference(robot, reference.X, gip->predict(reference.X), o);
  std::cout << "RMS tracking error per joint\n  PD alone  " << pd.rms_error.transpose() << "\n  ideal     "
            << ideal.rms_error.transpose() << "\n  fe        " << with_fe.rms_error.transpose() << "\n  gip       "
            << with_gip.rms_error.transpose() << "\n";
  for (int j = 0; j < 4; ++j) {
    EXPECT_LT(ideal.rms_error(j), 0.1 * pd.rms_error(j)) << "joint " << j + 1;
    // fe fitted to noisy torques: within a few times the ideal loop.
    EXPECT_LT(with_fe.rms_error(j), 5.0 * ideal.rms_error(j) + 1e-6) << "joint " << j + 1;
    EXPECT_LT(with_gip.rms_error(j), pd.rms_error(j)) << "joint " << j + 1;
  }
  EXPECT_EQ(pd.q.rows(), 1000);
  EXPECT_TRUE(pd.kp.allFinite() && (pd.kp.array() > 0).all());
}

// Computed torque asks the model at the measured state: with the robot's own
// dynamics (and with fe, exact up to its fit) the error decays at the chosen
// bandwidth, well below PD; a model that is wrong about M is hurt by it.
TEST(ClosedLoop, ComputedTorqueWithTheRightModelTracks) {
  const RobotModel robot = scara_robot();
  const SimulationResult reference = trajectory(1000, 0.001, 12, 0.0);
  TrackingOptions o;
  const TrackingResult pd = track_reference(robot, reference.X, Eigen::MatrixXd::Zero(1000, 4), o);
  const TrackingResult ct = track_computed_torque(
      robot, reference.X, [&](const Eigen::VectorXd& x) { return inverse_dynamics(robot, x.head(4), x.segment(4, 4), x.tail(4)); },
      o);
  const auto fe = test::fit_on_scara("fe", trajectory(300, 0.1, 11, 0.01));
  const TrackingResult fe_ct = track_computed_torque(
      robot, reference.X, [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return fe->predict(x.transpose()).row(0).transpose(); }, o);
  std::cout << "computed torque RMS error: true " << ct.rms_error.transpose() << "; fe " << fe_ct.rms_error.transpose()
            << "\n";
  for (int j = 0; j < 4; ++j) {
    EXPECT_LT(ct.rms_error(j), 0.05 * pd.rms_error(j)) << "joint " << j + 1;
    EXPECT_LT(fe_ct.rms_error(j), 0.2 * pd.rms_error(j)) << "joint " << j + 1;
  }
  EXPECT_NE(test::error_of([&] { track_computed_torque(robot, reference.X, {}, o); }).find("needs a model"),
            std::string::npos);
}

// Sensor noise reaches the controller, not the robot's state: tracking gets
// worse with it, the same seed gives the same run, another seed another one.
TEST(ClosedLoop, SensorNoiseIsSeededAndDegradesTracking) {
  const RobotModel robot = scara_robot();
  const SimulationResult reference = trajectory(1000, 0.001, 12, 0.0);
  const Eigen::MatrixXd ff = inverse_dynamics(robot, reference.X);
  TrackingOptions o;
  const TrackingResult clean = track_reference(robot, reference.X, ff, o);
  o.position_noise = 1e-2;
  o.velocity_noise = 1e-1;
  o.noise_seed = 5;
  const TrackingResult noisy = track_reference(robot, reference.X, ff, o);
  const TrackingResult again = track_reference(robot, reference.X, ff, o);
  o.noise_seed = 6;
  const TrackingResult other = track_reference(robot, reference.X, ff, o);
  EXPECT_EQ(noisy.q, again.q);
  EXPECT_NE(noisy.q, other.q);
  std::cout << "RMS error, exact feed-forward: clean " << clean.rms_error.transpose() << "; noisy "
            << noisy.rms_error.transpose() << "\n";
  for (int j = 0; j < 4; ++j) {
    EXPECT_GT(noisy.rms_error(j), 1.1 * clean.rms_error(j)) << "joint " << j + 1;
    // The plant filters the PD's reaction to white noise: the error stays below the noise.
    EXPECT_LT(noisy.rms_error(j), o.position_noise) << "joint " << j + 1;
  }
  EXPECT_GT((noisy.rms_error.array() / clean.rms_error.array()).maxCoeff(), 10.0);
  // The torques carry the noise through the PD terms.
  EXPECT_GT((noisy.tau - clean.tau).cwiseAbs().maxCoeff(), 0.0);
}

TEST(ClosedLoop, BadInputIsNamed) {
  const RobotModel robot = scara_robot();
  const SimulationResult reference = trajectory(50, 0.001, 1, 0.0);
  TrackingOptions o;
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(49, 4), o); })
                .find("one row of 4 per reference row"),
            std::string::npos);
  o.kp = Eigen::VectorXd::Ones(3);
  o.kd = Eigen::VectorXd::Ones(3);
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("TrackingOptions::kp and kd need one gain per joint"),
            std::string::npos);
  o = TrackingOptions();
  o.velocity_noise = -1.0;
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("TrackingOptions::velocity_noise must be"),
            std::string::npos);
  o = TrackingOptions();
  o.kp = Eigen::VectorXd::Constant(4, 1e9);  // far too stiff for 1 ms steps
  o.kd = Eigen::VectorXd::Constant(4, 1e7);
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("diverged at step"),
            std::string::npos);
  // The message names the setting that made the gains: explicit gains, or the bandwidth.
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("lower the gains (TrackingOptions::kp and kd)"),
            std::string::npos);
  o = TrackingOptions();
  o.bandwidth = 1e5;
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("lower the gains (TrackingOptions::bandwidth)"),
            std::string::npos);
  // Friction asked of a robot that has none would silently track a frictionless robot.
  std::vector<JointSpec> joints = robot.joints();
  for (auto& j : joints) j.friction = JointFriction();
  const RobotModel frictionless = RobotModel::from_dh("frictionless", joints, robot.gravity());
  o = TrackingOptions();
  o.friction = true;
  EXPECT_NE(test::error_of([&] { track_reference(frictionless, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("TrackingOptions::friction asks for friction, but robot 'frictionless' has none"),
            std::string::npos);
  EXPECT_NO_THROW(track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o));
  SimulationOptions so;
  so.samples = 10;
  so.friction = true;
  EXPECT_NE(test::error_of([&] { simulate(frictionless, so); }).find("SimulationOptions::friction asks for friction"),
            std::string::npos);
}

}  // namespace
}  // namespace gipdyn
