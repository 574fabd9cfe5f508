#pragma once
// Closed-loop tracking, the figure of merit of a model in a controller: the
// true robot (KDL dynamics, optionally with friction) follows a reference
// trajectory at the control rate under
//   tau = tau_ff(q_ref, qd_ref, qdd_ref) + Kp (q_ref - q) + Kd (qd_ref - qd),
// where tau_ff is a model's feed-forward torque (zero for PD alone, the
// robot's own inverse dynamics for the ideal case).
#include <Eigen/Dense>
#include <cstdint>
#include <functional>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

struct TrackingOptions {
  double dt = 0.001;  // control period (s): the reference's sampling period
  // PD gains per joint; empty: critically damped at `bandwidth` rad/s on each
  // joint's own inertia at the start, Kp = w^2 M_jj, Kd = 2 w M_jj.
  Eigen::VectorXd kp, kd;
  double bandwidth = 10.0;
  bool friction = false;  // the true robot has its viscous and Coulomb friction
  // Sensor noise: the controller sees q + N(0, position_noise^2) and
  // qd + N(0, velocity_noise^2) per joint and step (rad or m, and per second);
  // the robot moves on its true state. Seeded: the same seed gives every
  // controller the same noise sequence.
  double position_noise = 0.0, velocity_noise = 0.0;
  std::uint64_t noise_seed = 0;
  // The torque the environment applies to each joint at each step (steps x n,
  // N m or N; contact_torques() draws contacts as simulate does): it acts
  // through the robot's dynamics, M qdd + C qd + g = tau + external, and no
  // controller sees it. Empty: none.
  Eigen::MatrixXd external;
  void validate(int joints) const;  // throws gipdyn::Error naming the field
};

struct TrackingResult {
  Eigen::MatrixXd q;      // steps x n: the robot's positions
  Eigen::MatrixXd qd, qdd;  // steps x n: its velocities and true accelerations (a log of the loop, with tau)
  Eigen::MatrixXd tau;    // steps x n: the applied torques
  Eigen::VectorXd kp, kd;  // the gains used
  Eigen::VectorXd rms_error, max_error;  // per joint, |q_ref - q|
  Eigen::VectorXd rms_torque;            // per joint: the effort
};

// PD gains critically damped at `bandwidth` rad/s on each joint's own inertia
// at q: Kp = w^2 M_jj(q), Kd = 2 w M_jj(q).
void critically_damped_gains(const RobotModel& robot, const Eigen::VectorXd& q, double bandwidth, Eigen::VectorXd& kp,
                             Eigen::VectorXd& kd);

// reference: steps x 3n (q, qd, qdd) at options.dt; feedforward: steps x n.
// The robot starts on the reference (q, qd of its first row) and is
// integrated by semi-implicit Euler at dt. Throws gipdyn::Error for bad shapes
// and when the motion diverges (naming the step).
TrackingResult track_reference(const RobotModel& robot, const Eigen::MatrixXd& reference,
                               const Eigen::MatrixXd& feedforward, const TrackingOptions& options);

// Computed-torque control with an inverse dynamics model f (x = (q, qd, qdd)
// -> tau): at the measured state the model is asked for the torque that gives
// the commanded acceleration,
//   tau = f(q, qd, qdd_ref + w^2 (q_ref - q) + 2 w (qd_ref - qd)),  w = bandwidth,
// so every joint's error obeys e'' + 2 w e' + w^2 e = 0 where f is exact. Any
// estimator can serve (it needs no explicit M); options.kp and kd are unused.
using InverseDynamicsFunction = std::function<Eigen::VectorXd(const Eigen::VectorXd& x)>;
TrackingResult track_computed_torque(const RobotModel& robot, const Eigen::MatrixXd& reference,
                                     const InverseDynamicsFunction& model, const TrackingOptions& options);

}  // namespace gipdyn
