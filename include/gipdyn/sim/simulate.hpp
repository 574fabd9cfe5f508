#pragma once
// Simulated datasets (docs/method.md section 5): a random sinusoid trajectory, torques from
// the rigid-body model (KDL), optional friction, i.i.d. Gaussian noise, and
// optionally a kinematic perturbation of the generating model (model bias).
#include <Eigen/Dense>
#include <cstdint>
#include <nlohmann/json.hpp>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/robot/robot_model.hpp"
#include "gipdyn/sim/trajectory.hpp"

namespace gipdyn {

// External torques on the robot (contacts), the ground truth that contact
// detection is measured against. With count > 0 the log is no longer the
// reference trajectory played back: the robot follows it under a PD
// controller around the trajectory's own torques, which runs ten times per
// row and at least at 1 kHz, and each contact, a constant torque on one joint for `duration`
// seconds, acts through the forward dynamics. The logged torque is the
// controller's (what a robot's joint sensors measure), the logged qdd the
// robot's true acceleration, so that
//   M(q) qdd + C(q, qd) qd + g(q) = tau + tau_ext
// holds on every row, and tau_ext is written beside the log.
struct SimulatedContacts {
  int count = 0;
  // Each contact's torque: this fraction of its joint's torque range (max - min
  // over the contact-free motion), with a random sign.
  double size = 0.1;
  double duration = 0.05;  // s
  int joint = 0;           // the joint (1..n) every contact acts on; 0: each on a joint drawn at random
  double bandwidth = 30.0;  // rad/s: the PD's gains, Kp = w^2 M_jj(q0), Kd = 2 w M_jj(q0)
  // Throws gipdyn::Error naming the field.
  void validate(int joints, int samples, double dt) const;
  // {"count", "size", "duration_s", "joint"}, and "bandwidth" where the PD
  // above plays the log back (simulate), the record every folder and log sidecar keeps.
  nlohmann::json to_json(bool with_bandwidth) const;
};

struct SimulationOptions {
  int samples = 2000;
  std::uint64_t seed = 0;
  double noise_std = 0.01;  // N m (N for prismatic joints)
  double dt = 0.01;         // s: 100 Hz; 2000 samples cover 20 s of motion
  bool perturb_kinematics = false;
  double perturb_length = 0.05;     // m
  double perturb_angle_deg = 5.0;   // deg
  bool friction = false;
  TrajectoryOptions trajectory;
  SimulatedContacts contacts;
  void validate() const;  // throws gipdyn::Error
};

struct SimulationResult {
  Eigen::MatrixXd X;         // samples x 3n: q, qd, qdd
  Eigen::MatrixXd tau;       // with noise
  Eigen::MatrixXd tau_true;  // noise-free
  Eigen::MatrixXd external;  // samples x n: the true external torque (SimulatedContacts); empty without contacts
  nlohmann::json metadata;   // everything needed to regenerate the data; "generator": kSimulationGenerator
};

// What simulate records as a log's "generator", so that a reader can tell a simulated log from a robot's.
inline constexpr const char* kSimulationGenerator = "gipdyn simulate";

// Independent seeds for the trajectory, the noise and the perturbation are
// derived from options.seed, so the same seed gives the same data.
SimulationResult simulate(const RobotModel& nominal, const SimulationOptions& options);

// The external torque of `contacts` at the times k dt of the rows of
// reference_torque (rows x n), drawn as simulate draws them: one contact in
// each of count equal slots of the motion, on contacts.joint or a drawn joint,
// of contacts.size times that joint's range in reference_torque, with a drawn
// sign; seeded. For a closed loop of one's own (TrackingOptions::external).
// `drawn`, where given, gets each contact's {"start_s", "joint", "torque"}.
// Throws gipdyn::Error as SimulatedContacts::validate.
Eigen::MatrixXd contact_torques(const SimulatedContacts& contacts, const Eigen::MatrixXd& reference_torque, double dt,
                                std::uint64_t seed, nlohmann::json* drawn = nullptr);

}  // namespace gipdyn
