#pragma once
// The table of estimators: the only place an estimator's name is spelled.
// Every GP kernel of kernels/kernel_factory.hpp is an estimator of the GP
// family; lip, lip+friction, fe, chain and nn follow. Dispatch, model files,
// presets, the front ends' help and lists, and the experiments read this table.
#include <string>
#include <vector>

#include "gipdyn/model/hyperparameter_search.hpp"

namespace gipdyn {

struct KernelSpec;

// How an estimator is fitted and stored: its model file's "estimator" entry.
enum class EstimatorFamily { Gp, Lagrangian, Fisherian, NeuralNetwork };

struct EstimatorSpec {
  std::string name;
  EstimatorFamily family = EstimatorFamily::Gp;
  std::string help;  // one line
  // Needs a nominal robot (RobotPrior::robot): fe and the model-based kernels.
  bool needs_robot = false;
  // Lagrangian: each joint's smooth friction and offset beside the energies.
  bool friction = false;
  // Fisherian: a serial chain's geometry identified from the log before the
  // least-squares fit (robot/chain_identification.hpp).
  bool identifies_chain = false;
  // Gravity, inertia and Coriolis torques out of a fitted model (physics.hpp).
  bool rigid_body_terms = false;
  // Hyperparameters by marginal likelihood, cost cubic in the rows (the GP kernels, lip).
  bool kernel_method = false;
  // A predictive standard deviation beside the torque (uncertainty.hpp).
  bool predictive_variance = false;
  // Kernel methods: the restarts of its hyperparameter search, their spread
  // and their screening, where SearchSettings leaves them unset. An NLL with
  // several deep optima needs restarts wider than the data-driven start's
  // neighbourhood, each run to its end: the leader after a short budget is
  // not the deepest (bench/RESULTS.md, "A wider restart spread").
  int restarts = SearchSettings::kDefaultRestarts;
  double restart_spread = SearchSettings::kDefaultRestartSpread;
  int start_screening_evaluations = SearchSettings::kDefaultStartScreening;
  // The estimator train fits by default, and the one that teaches it by
  // default (TeacherOptions::name; fit_estimator.hpp's automatic teaching).
  bool default_estimator = false, default_teacher = false;
  // The preset (presets.hpp) that chooses this estimator, empty for none, and
  // the most rows it trains on (a constant-step subsample of longer logs); 0: every row.
  std::string preset;
  int preset_max_training_rows = 0;
  // A candidate of the choice by evidence (model_selection.hpp) where above 0:
  // of candidates that score alike, the lowest rank wins. It is fitted on at
  // most selection_max_rows rows (a constant-step subsample; 0: every row),
  // where its fit stays in minutes.
  int selection_rank = 0;
  int selection_max_rows = 0;
  // Compared by the experiment commands unless they are given a list (those
  // that need a robot only where one is known).
  bool compared_by_default = false;
  // In the GIP paper's comparisons on simulated data, which the accuracy and
  // data-efficiency experiments reproduce unless they are given a list:
  // accuracy under model bias (the model-based estimators on the nominal
  // robot against the data-driven ones), and test error against the number of
  // training samples.
  bool in_paper_accuracy_comparison = false;
  bool in_paper_data_efficiency_comparison = false;
  // GP family: the row of kernel_table(); null for the others.
  const KernelSpec* kernel = nullptr;
};

// Every estimator, the GP kernels first.
const std::vector<EstimatorSpec>& estimator_table();
// The row of `name`, or null where no estimator has that name.
const EstimatorSpec* find_estimator_spec(const std::string& name);
// The row of `name`; throws gipdyn::Error listing the valid names otherwise.
const EstimatorSpec& estimator_spec(const std::string& name);
// The table's names, in order; those whose row satisfies `keep`.
const std::vector<std::string>& estimator_names();
std::vector<std::string> estimator_names_where(bool (*keep)(const EstimatorSpec&));
// The estimators compared_by_default, those that need a robot with robot_known only;
// those that need a robot, alone.
std::vector<std::string> default_compared_estimators(bool robot_known);
std::vector<std::string> robot_compared_estimators();
// The rows in_paper_accuracy_comparison, and in_paper_data_efficiency_comparison.
std::vector<std::string> paper_accuracy_estimators();
std::vector<std::string> paper_data_efficiency_estimators();
// The candidates of the choice by evidence, by selection_rank.
std::vector<std::string> selection_candidates();
// The rows marked default_estimator and default_teacher.
const std::string& default_estimator_name();
const std::string& default_teacher_name();
// The name of the row of `family` whose column `variant` is `on` (without a
// variant: the family's first row), e.g. estimator_name(EstimatorFamily::Lagrangian,
// &EstimatorSpec::friction, true) for LIP with friction.
const std::string& estimator_name(EstimatorFamily family, bool EstimatorSpec::*variant = nullptr, bool on = false);

// The estimators' own search starts, one clause each where it differs from
// SearchSettings' default, for help text: "rbf 10 at spread 2; the others
// none" and "rbf 0; the others 60".
std::string restart_defaults_summary();
std::string start_screening_defaults_summary();

// Readers of the table's columns, for valid names (else they throw as estimator_spec).
EstimatorFamily estimator_family(const std::string& name);
bool is_gp_estimator(const std::string& name);
bool is_kernel_estimator(const std::string& name);
bool estimator_needs_robot(const std::string& name);
void require_known_estimator(const std::string& name);

}  // namespace gipdyn
