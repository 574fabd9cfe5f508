#pragma once
// Learning from a teacher. One estimator (the teacher, e.g. LIP) is fitted on
// the logged rows; it then labels states drawn uniformly from the box the log
// spans (each of q, qd, qdd of every joint between its smallest and largest
// logged value) with its torques; another estimator (the student, e.g. GIP)
// learns from those labels, with the teacher's residual on the log as its
// noise floor. On one short motion the student then extrapolates like the
// teacher, at its own cost a query: LIP's structure, GIP's microseconds
// (docs/results/training.md, "GIP taught by LIP"). The student is as good as the
// teacher is over the box, not better.
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

// When a student learns from its teacher instead of from the log.
enum class TeachingMode {
  // Always: the taught model is kept even where it misses the log (its
  // TeachingCheck warns).
  Always,
  // Where it pays: only on a log of at most TeacherOptions::automatic_max_log_values
  // values of torque (rows x joints), and the taught model is kept only if it
  // passes its TeachingCheck; otherwise, and where the teacher fails, the
  // estimator learns from the log itself. On a short simulated motion the
  // taught model passes and extrapolates like its teacher; on a real robot's
  // log it misses the log and the estimator's own fit is kept
  // (docs/results/training.md, "GIP taught by LIP"). fit_estimator teaches in this mode
  // only where automatic_teaching_applies (fit_estimator.hpp).
  Automatic,
};

std::string to_string(TeachingMode mode);

struct TeacherOptions {
  // An estimator of estimator_registry.hpp that needs no nominal robot.
  std::string name = default_teacher_name();
  // States drawn from the box, labelled by the teacher: the student's training rows.
  int states = 2000;
  // The teacher learns its hyperparameters on a constant-step subsample of this
  // many logged rows, then is conditioned on all of them (SearchSettings::
  // hyperparameter_rows; a LIP system is (N n) x (N n)). 0: on every row.
  int hyperparameter_rows = 300;
  // The student learns its hyperparameters on a constant-step subsample of
  // this many drawn states, then is conditioned on all of them. The states are
  // independent draws over the whole box, so a few hundred of them tell the
  // NLL what thousands do (docs/results/training.md compares them) at a fraction of
  // an evaluation's O(N^3).
  // 0: on every state. SearchSettings::hyperparameter_rows, when above 0, wins.
  int student_hyperparameter_rows = 500;
  // Seed of the drawn states.
  std::uint64_t seed = 0;
  TeachingMode mode = TeachingMode::Always;
  // With TeachingMode::Automatic: the longest log, in rows x joints, that is
  // taught. A LIP teacher is conditioned on all N n torques, an (N n) x (N n)
  // system (14000: 1.5 GiB, a 7-joint log of 2000 rows); a longer log fills
  // more of its box by itself.
  long automatic_max_log_values = 14000;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
  // Whether a log of this many rows of this many joints is taught (mode,
  // automatic_max_log_values).
  bool teaches(Eigen::Index rows, Eigen::Index joints) const;
  // The teacher's search: the student's (every setting, and any added later,
  // reaches the teacher), on hyperparameter_rows of this struct.
  SearchSettings teacher_search(const SearchSettings& student) const;
  // The student's own search: `student` with its hyperparameter subsample
  // (SearchSettings::hyperparameter_rows, else student_hyperparameter_rows).
  SearchSettings student_search(const SearchSettings& student) const;
};

// Where the teacher's residual on the log is at least this share of a
// joint's logged torque variance, the teacher has learned (almost) nothing of
// that joint, and its torques at the drawn states are extrapolation of noise:
// that joint is labelled with its logged mean instead. The threshold lies
// between the shares at which taught joints tested worse than their mean and
// those at which teaching still helped (docs/results/training.md, "GIP taught by LIP").
inline constexpr double kTeacherNoiseShareForMeanLabels = 0.93;

struct TeachingSet {
  FitReport teacher_report;
  std::unique_ptr<Estimator> teacher;  // null unless teacher_report.ok()
  Eigen::MatrixXd X;                   // TeacherOptions::states x 3n: the drawn states
  // states x n: the teacher's torques (its posterior mean, without noise); a
  // joint's logged mean (its constant) where the teacher learned nothing of it
  // (kTeacherNoiseShareForMeanLabels)
  Eigen::MatrixXd Y;
  // Per joint: the root mean square of the teacher's residual on the logged
  // rows, how precisely the teacher knows the torque: the labels' uncertainty.
  Eigen::VectorXd label_noise_std;
  // Per joint: the student's noise floor (GpOptions::noise_std_floor),
  // label_noise_std where the labels are the teacher's torques, 0 where they
  // are a constant. Labels without noise and a student that may not call less
  // than the teacher's residual noise: the student smooths the teacher's
  // torques as the teacher smoothed the log, and does not interpolate them
  // (docs/results/training.md, "The student's noise floor").
  Eigen::VectorXd student_noise_std_floor;
};

// A student misses a joint of the log when its nMSE on the logged rows
// exceeds its teacher's both by more than kTaughtNmseGapWarning and by more
// than the factor kTaughtResidualRatioWarning. The student learns the
// teacher's torques over the whole box of the log; where the log's states fill
// that box (simulated motions), it fits the log as its teacher does; where
// they lie on a thin set of it (a real robot's log), the teacher's torques
// over the box are extrapolation and the student can miss the log by more
// than the torque's variance (docs/results/training.md measures both). The ratio
// spares a joint whose torque is mostly noise: there the teacher's own
// residual is near the torque's variance, and a student that adds a fraction
// of that noise has lost nothing the log could teach.
inline constexpr double kTaughtNmseGapWarning = 0.1;
inline constexpr double kTaughtResidualRatioWarning = 2.0;

// A student that passes can still fit a joint's logged rows far worse than
// its teacher: at least kTeacherFarAheadRatio times its nMSE, and above
// kTeacherFarAheadFloor, below which both are as good as any user needs.
// There the teacher is likely the more accurate model on new motions too, at
// its slower query (docs/results/training.md shows a 7R arm's joint 1).
inline constexpr double kTeacherFarAheadRatio = 10.0;
inline constexpr double kTeacherFarAheadFloor = 1e-3;

// How well the teacher and its student fit the logged rows they came from.
struct TeachingCheck {
  Eigen::VectorXd teacher_nmse;  // per joint: the teacher's MSE on the logged rows over the torque's variance
  Eigen::VectorXd student_nmse;  // the same for the student; NaN where the logged torque is constant
  // One line naming every joint the student misses (kTaughtNmseGapWarning), with
  // both nMSE, and what to do instead; "" when none.
  std::string warning(const std::string& teacher_name) const;
  // The student misses no joint (kTaughtNmseGapWarning).
  bool passed() const;
  // The joints (0-based) whose logged rows the teacher fits far better than
  // the student (kTeacherFarAheadRatio) and that the student does not miss
  // (warning() names those), in order.
  std::vector<int> joints_teacher_far_ahead() const;
};

// The check from the logged torques Y (N x n), the teacher's RMS residual on
// them (TeachingSet::label_noise_std) and the student's predictions at the
// logged states (N x n).
TeachingCheck check_teaching(const Eigen::MatrixXd& Y, const Eigen::VectorXd& teacher_residual_rms,
                             const Eigen::MatrixXd& student_prediction);

// Labels TeacherOptions::states states drawn from the box of X with the
// torques of `teacher`, fitted on (X, Y) (teacher_report.ok(); fit_estimator.hpp's
// teach fits it), and sets their noise floors. options and the data are
// checked by the caller.
TeachingSet label_states(const TeacherOptions& options, std::unique_ptr<Estimator> teacher, FitReport teacher_report,
                         const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y);

}  // namespace gipdyn
