#pragma once
// Contact detection (docs/contact-detection.md): models learned from a
// contact-free simulated motion detect contacts that act through the
// simulated robot's dynamics on a new motion. Per model and method: how many
// contacts are found and how fast, how well their torque is estimated, and
// how often a contact-free motion raises a false alarm. The true robot's own
// dynamics (fe on the true robot) bounds what any learned model can do.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/progress.hpp"
#include "gipdyn/sensing/contact_detection.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace gipdyn {

struct ContactExperimentConfig {
  std::string robot = "scara";
  // Learned models (names of estimator_registry.hpp or STUDENT@TEACHER); the
  // true model is always added.
  std::vector<std::string> estimators{"gip@lip", "lip", "chain", "rbf"};
  int train_samples = 2000;
  double train_dt = 0.01;   // s: the training motion's sampling period
  double seconds = 20.0;    // each of the calibration, contact and contact-free motions
  double dt = 0.001;        // s: their sampling period (the control rate)
  double noise = 0.01;      // torque noise std of every motion
  SimulatedContacts contacts{20, 0.1, 0.05, 0, 30.0};
  // The detectors' options but the method (both are run) and the sample time (dt).
  ContactOptions detection;
  std::uint64_t seed = 0;
  EstimatorOptions base;  // search settings shared by the fits
  std::string out;
  void validate() const;  // throws gipdyn::Error
  nlohmann::json to_json() const;
};

// Writes contacts.csv (model, method, the scores), summary.md, and per model
// and method a CSV and PNG of its detection over the first seconds of the
// contact motion.
ExperimentOutcome run_contact_experiment(const ContactExperimentConfig& config, const ProgressCallback& progress = {});

}  // namespace gipdyn
