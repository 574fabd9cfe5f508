#pragma once
// Choosing an estimator by evidence. No fixed rule picks the best model of
// every log (a simulated arm, a real arm with friction, a log of one motion or
// of many), so the candidates of the estimator table (selection_candidate) are
// each fitted on the earlier part of the log and scored on its later part,
// a block of time the fits did not see; the best is refitted on the whole log.
// The choice is made per joint: where candidates lead on different joints,
// each joint keeps the one that predicted it best (per_joint_estimator.hpp).
#include <Eigen/Dense>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"

namespace gipdyn {

// The name front ends give for "choose by evidence" where they take an estimator's name.
inline constexpr const char* kAutomaticEstimator = "auto";

struct SelectionOptions {
  // Names from the estimator table, in order of preference; empty: selection_candidates().
  std::vector<std::string> candidates;
  // The last held_out_fraction of the log's rows (in the order logged) score the candidates.
  double held_out_fraction = 0.25;
  // Candidates whose mean held-out nMSE is within this fraction of the best score alike: differences that
  // small are within what one block of a noisy log can tell apart. Of those, the first in candidates wins.
  double tie_tolerance = 0.05;
  // A joint leaves the choice by mean nMSE only for a candidate whose held-out nMSE on it is below the mean
  // choice's divided by this. One held-out block of a real log is a noisy judge of one joint, and small leads on
  // it need not carry over to new motion (docs/results/experiments/model-choice). At least 1.
  double per_joint_factor = 2.0;
  // Throws gipdyn::Error naming the field.
  void validate() const;
};

struct CandidateScore {
  std::string name;
  bool ok = false;
  std::string failure;       // why it has no score (a failed fit, options it cannot honour)
  Eigen::VectorXd nmse;      // per joint, on the held-out rows
  double mean_nmse = 0.0;    // over the joints; +inf without a score
  Eigen::Index fit_rows = 0; // the rows it was fitted on
  double seconds = 0.0;      // its fit and prediction
};

struct Selection {
  std::vector<CandidateScore> candidates;  // in the order fitted
  // The first candidate within SelectionOptions::tie_tolerance of the lowest mean nMSE; empty where none has a score.
  std::string chosen;
  std::string best;  // the lowest mean nMSE
  // Per joint: `chosen`, unless the joint's lowest held-out nMSE is below chosen's on it divided by
  // SelectionOptions::per_joint_factor (never for a joint whose held-out torque is constant); then the first
  // candidate in the order of preference within SelectionOptions::tie_tolerance of that lowest nMSE. Empty where
  // none has a score.
  std::vector<std::string> chosen_per_joint;
  // Whether the joints chose different candidates: the model is then a PerJointEstimator of them.
  bool per_joint() const;
  Eigen::Index fit_rows = 0, held_out_rows = 0;
  double tie_tolerance = 0.0;     // SelectionOptions::tie_tolerance
  double per_joint_factor = 1.0;  // SelectionOptions::per_joint_factor
  // A table of the candidates' held-out nMSE per joint and mean, and a line saying what was chosen and why.
  std::string brief_report() const;
  // The model file's "selection" block (docs/model-format.md).
  nlohmann::json record() const;
};

// The options of candidate `name` under the user's `base` options (its search,
// threads, seed, teacher settings): the GP's search as given; gip taught by
// its automatic teacher (choose_teacher "auto"); lip with the search that
// teacher has (TeacherOptions::teacher_search), so that gip's teacher is the
// lip candidate and is scored as it, without a second fit. Restarts only
// where `base` gives them: a candidate's own (EstimatorSpec::restarts) would
// multiply the choice's cost to sharpen a score that ranks held-out error, not
// the NLL (the chosen one's refit on the whole log has the options it was scored with).
EstimatorOptions candidate_options(const std::string& name, const EstimatorOptions& base,
                                   const TeacherOptions& teacher_settings = {});

// The rows a candidate is fitted on out of `rows`: a constant-step subsample
// of at most its table's selection_max_rows.
std::vector<Eigen::Index> candidate_rows(const std::string& name, Eigen::Index rows);

struct SelectionResult {
  Selection selection;
  // The chosen candidate refitted on the whole log, or with Selection::per_joint() a PerJointEstimator of every
  // chosen candidate refitted (its report: each joint's from its model's fit); its estimator holds selection.record().
  FitResult fit;
  EstimatorOptions options;    // the chosen candidate's options (with per_joint(): Selection::chosen's)
  Eigen::Index refit_rows = 0; // the rows of the whole log it (the most of them) was refitted on
};

// Scores every candidate (Selection) and refits the chosen ones on (X, Y) (their rows
// as candidate_rows says). Bad options or data, or a log too short to hold
// out a block, throw gipdyn::Error before any work; where no candidate fits,
// the result's fit.report says why. progress sees every candidate's fit.
SelectionResult fit_selected_estimator(const EstimatorOptions& base, const SelectionOptions& options,
                                       const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                                       const TeacherOptions& teacher_settings = {},
                                       const ProgressCallback& progress = {});

}  // namespace gipdyn
