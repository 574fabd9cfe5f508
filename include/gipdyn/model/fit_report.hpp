#pragma once
// What a fit did, for every estimator: a status, a one-line reason when it
// failed, the time it took and, for GP estimators, one report per joint.
// Training and fitting return it beside the model instead of throwing from
// inside the numerics (bad options and data still throw gipdyn::Error at the
// entry point, before any work).
#include <limits>
#include <string>
#include <vector>

#include "gipdyn/optim/optimizer.hpp"

namespace gipdyn {

enum class FitStatus {
  Converged,     // every joint's optimiser met its stopping rule
  NotConverged,  // a usable model, but some joint stopped at its iteration cap or stalled
  Completed,     // a fixed schedule ran to its end (the network's epochs): nothing to converge to or to cut short
  Failed,        // no model: see FitReport::message
};
std::string to_string(FitStatus status);

struct JointReport {
  int joint = 0;  // 0-based
  double nll = 0.0;
  std::vector<double> restart_nlls;  // one per start (on the warm-start subsample if any), NaN where a start failed
  int evaluations = 0;      // NLL evaluations on all rows (or the hyperparameter rows)
  int warm_start_evaluations = 0;  // NLL evaluations on the warm-start subsample, over every start
  // Screened starts (SearchSettings::start_screening_evaluations): the starts
  // behind the leader stopped after this many evaluations, so their
  // restart_nlls are those of that point. 0: every start ran to its end.
  int screening_evaluations = 0;
  // The rows the hyperparameters were learned on when a subsample
  // (SearchSettings::hyperparameter_rows), else 0: learned on every row.
  long hyperparameter_rows = 0;
  double grad_norm = 0.0;   // projected |dNLL/dtheta|_inf at the kept point
  double noise_variance = 0.0;  // learned, in units of the scaled output (a share of its variance when standardised)
  // The learned noise variance over the mean square of the scaled output the
  // joint's GP fits, whatever the scaling: near 1, the fit explains the torque
  // as noise and predicts little more than its mean. NaN where unknown (files
  // written before it existed).
  double noise_share = std::numeric_limits<double>::quiet_NaN();
  double seconds = 0.0;
  double jitter = 0.0;
  OptimizerResult::Status status = OptimizerResult::Status::Failed;  // of the kept start
  std::string message;
  // Learned in one optimisation with every other joint (lip, whose energies
  // couple the joints): status, NLL, evaluations, gradient, starts, jitter and
  // seconds are that one fit's, the same in every joint's report; only the
  // noise differs. Reports and warnings then speak of the fit once.
  bool coupled = false;
};

// True when there are several joints and every joint's report is that of one
// coupled fit (JointReport::coupled).
bool one_coupled_fit(const std::vector<JointReport>& joints);

// A joint whose fit calls at least this share of the torque noise is warned about.
inline constexpr double kNoiseShareWarning = 0.5;

// The warning about the joints whose noise_share reaches kNoiseShareWarning
// (one line naming each with its share), or "" when there are none.
std::string noise_share_warning(const std::vector<JointReport>& joints);

// The warnings about joints that stopped before converging: one line for those
// at OptimizerOptions::max_iterations, one for those whose line search stalled;
// empty when every joint converged. A coupled fit is named once, not joint by joint.
std::vector<std::string> convergence_warnings(const std::vector<JointReport>& joints);

struct FitReport {
  FitStatus status = FitStatus::Failed;
  std::string message;  // on failure: which joint and why
  double seconds = 0.0;
  std::vector<JointReport> joints;  // GP estimators: one per joint

  bool ok() const { return status != FitStatus::Failed; }
  // A few lines for people: status, then a table of the joints (status, NLL,
  // evaluations, gradient, noise, jitter, seconds) and the NLL of every start
  // when there were restarts; a coupled fit (one_coupled_fit) gets one row and
  // its joints' noise on a line of its own.
  std::string brief_report() const;
  // One line per problem a user should act on: joints that did not converge
  // (naming OptimizerOptions::max_iterations), joints that needed jitter, joints
  // whose fit calls most of the torque noise (noise_share at least
  // kNoiseShareWarning).
  std::vector<std::string> warnings() const;
};

// FitStatus from the joints' optimiser statuses (Failed if any joint failed).
FitStatus combine_joint_statuses(const std::vector<JointReport>& joints);

}  // namespace gipdyn
