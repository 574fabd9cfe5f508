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

// An external torque acts through the robot's dynamics and no controller sees
// it: a constant push on a robot held still by PD plus gravity feed-forward
// settles at q - q0 = Kp^-1 tau_ext (the SCARA's gravity does not depend on q),
// and every logged row satisfies the robot's inverse dynamics, KDL's, with
// the push added to the controller's torque.
TEST(ClosedLoop, AnExternalTorqueActsThroughTheDynamicsAndNoControllerSeesIt) {
  const RobotModel robot = scara_robot();
  const int steps = 2000;  // 2 s at 1 kHz
  Eigen::VectorXd q0(4);
  q0 << 0.3, -0.5, 0.1, 0.2;
  Eigen::MatrixXd reference = Eigen::MatrixXd::Zero(steps, 12);
  reference.leftCols(4).rowwise() = q0.transpose();
  const Eigen::MatrixXd hold = inverse_dynamics(robot, reference);
  TrackingOptions o;
  const TrackingResult still = track_reference(robot, reference, hold, o);
  EXPECT_LT((still.q - reference.leftCols(4)).cwiseAbs().maxCoeff(), 1e-10);
  Eigen::VectorXd push(4);
  push << 0.4, 0.0, -2.0, 0.0;
  o.external = Eigen::MatrixXd::Zero(steps, 4);
  o.external.bottomRows(steps - 200).rowwise() = push.transpose();
  const TrackingResult pushed = track_reference(robot, reference, hold, o);
  const Eigen::VectorXd settled = pushed.q.bottomRows(1).transpose() - q0;
  const Eigen::VectorXd expected = push.cwiseQuotient(pushed.kp);
  for (int j = 0; j < 4; ++j) EXPECT_NEAR(settled(j), expected(j), 1e-3 * expected.cwiseAbs().maxCoeff()) << "joint " << j + 1;
  EXPECT_GT(std::abs(settled(0)), 1e-4);  // it moved
  for (Eigen::Index k : {Eigen::Index{100}, Eigen::Index{250}, Eigen::Index{1999}}) {
    const Eigen::VectorXd tau = inverse_dynamics(robot, pushed.q.row(k).transpose(), pushed.qd.row(k).transpose(),
                                                 pushed.qdd.row(k).transpose());
    EXPECT_LT((tau - pushed.tau.row(k).transpose() - o.external.row(k).transpose()).cwiseAbs().maxCoeff(), 1e-8)
        << "row " << k;
  }
}

// contact_torques draws contacts as simulate does: count pulses of the given
// duration, each on one joint at size times its range, seeded.
TEST(ClosedLoop, ContactTorquesArePulsesOfTheAskedSizeAndDuration) {
  const SimulationResult reference = trajectory(3000, 0.001, 5, 0.0);
  const Eigen::MatrixXd torque = inverse_dynamics(scara_robot(), reference.X);
  const Eigen::VectorXd range = torque.colwise().maxCoeff() - torque.colwise().minCoeff();
  SimulatedContacts c;
  c.count = 4;
  c.size = 0.2;
  c.duration = 0.05;
  nlohmann::json drawn;
  const Eigen::MatrixXd ext = contact_torques(c, torque, 0.001, 9, &drawn);
  ASSERT_EQ(ext.rows(), 3000);
  ASSERT_EQ(drawn.size(), 4u);
  int pushed_rows = 0;
  for (Eigen::Index k = 0; k < ext.rows(); ++k) {
    int active = 0;
    for (int j = 0; j < 4; ++j)
      if (ext(k, j) != 0.0) {
        ++active;
        EXPECT_NEAR(std::abs(ext(k, j)), 0.2 * range(j), 1e-12);
      }
    EXPECT_LE(active, 1);
    pushed_rows += active;
  }
  EXPECT_NEAR(pushed_rows, 4 * 50, 4);  // 50 rows of 1 ms each
  for (const auto& k : drawn) {
    const auto row = static_cast<Eigen::Index>(std::ceil(k.at("start_s").get<double>() / 0.001));
    EXPECT_EQ(ext(row, k.at("joint").get<int>() - 1), k.at("torque").get<double>());
  }
  EXPECT_EQ(contact_torques(c, torque, 0.001, 9), ext);
  EXPECT_NE(contact_torques(c, torque, 0.001, 10), ext);
  c.count = 40;
  EXPECT_NE(test::error_of([&] { contact_torques(c, torque, 0.001, 9); }).find("SimulatedContacts::count (40) contacts"),
            std::string::npos);
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
  o.external = Eigen::MatrixXd::Zero(49, 4);
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("TrackingOptions::external has 49 rows, and the reference 50: give one per step"),
            std::string::npos);
  o.external = Eigen::MatrixXd::Zero(50, 3);
  EXPECT_NE(test::error_of([&] { track_reference(robot, reference.X, Eigen::MatrixXd::Zero(50, 4), o); })
                .find("TrackingOptions::external needs one column per joint (4)"),
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
