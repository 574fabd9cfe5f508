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
  void validate() const;  // throws gipdyn::Error
};

struct SimulationResult {
  Eigen::MatrixXd X;         // samples x 3n: q, qd, qdd
  Eigen::MatrixXd tau;       // with noise
  Eigen::MatrixXd tau_true;  // noise-free
  nlohmann::json metadata;   // everything needed to regenerate the data; "generator": kSimulationGenerator
};

// What simulate records as a log's "generator", so that a reader can tell a simulated log from a robot's.
inline constexpr const char* kSimulationGenerator = "gipdyn simulate";

// Independent seeds for the trajectory, the noise and the perturbation are
// derived from options.seed, so the same seed gives the same data.
SimulationResult simulate(const RobotModel& nominal, const SimulationOptions& options);

}  // namespace gipdyn
