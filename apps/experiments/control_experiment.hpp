#pragma once
// Closed-loop tracking (docs/results/paper-experiments.md): the true simulated robot follows
// a held-out trajectory at the control rate under PD feedback plus each
// model's feed-forward torque, beside PD alone and the robot's own dynamics,
// and under computed-torque control with each model (rows named NAME-ct).
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

struct ControlConfig {
  std::string robot = "scara";
  std::vector<std::string> models;  // model files (any estimator); may be empty
  double seconds = 5.0;             // length of the reference trajectory
  double dt = 0.001;                // control period (s)
  double bandwidth = 10.0;          // PD: critically damped at this many rad/s per joint
  bool friction = false;            // the true robot has friction
  std::uint64_t seed = 0;           // of the reference trajectory and of the sensor noise
  double position_noise = 0.0, velocity_noise = 0.0;  // std of what the controllers measure
  // Contacts that push the robot during the run, drawn once (seeded by seed) and the same for every
  // controller; their size is a fraction of each joint's torque range along the reference. Its bandwidth is
  // unused: the controllers are the experiment's.
  SimulatedContacts contacts;
  std::string out;
  void validate() const;
  nlohmann::json to_json() const;
};
// Writes tracking.csv (controller, joint, rms_error, max_error, rms_torque),
// errors.csv (the position error of every controller over time), summary.md,
// tracking.png and, with contacts, external.csv (t, ext1..extn: the external
// torque that acted on the robot).
ExperimentOutcome run_control_experiment(const ControlConfig& config, const ProgressCallback& progress = {});

}  // namespace gipdyn
