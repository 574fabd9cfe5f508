#pragma once
// What every experiment does around its fits: a result folder whose
// config.json must match on resume, a log of failures, the time-left estimate,
// one fit-and-predict with its timing, and the bookkeeping after each fit.
#include <Eigen/Dense>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

struct ExperimentOutcome {
  int units_done = 0;      // fitted in this invocation
  int units_skipped = 0;   // already recorded by an earlier invocation
  int units_failed = 0;    // fits that failed (recorded as nan, with the reason in the log)
  std::vector<std::string> files;     // what was written
  std::vector<std::string> warnings;  // e.g. plots that could not be drawn
};

// Creates `out` and its config.json, or checks that an existing one equals `config`.
void prepare_folder(const std::string& out, const nlohmann::json& config);
// Appends a line to OUT/experiment.log.
void log_line(const std::string& out, const std::string& line);

// splitmix64 of a combination: well-separated seeds for (seed, run, purpose).
std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b);

// Estimates time left from the seconds each kind of unit took so far
// (including units recorded by earlier invocations).
class Eta {
 public:
  void record(const std::string& key, double seconds);
  void add_pending(const std::string& key, int units);
  void finish(const std::string& key);
  // Units that run side by side: the time left is the pending work over them.
  void set_concurrency(int units) { concurrency_ = units > 1 ? units : 1; }
  std::string left() const;

 private:
  int concurrency_ = 1;
  std::map<std::string, std::pair<double, int>> stats_;  // key -> (seconds, count)
  std::map<std::string, int> pending_;
};

struct FitAndPredict {
  bool ok = false;
  std::string message;
  double seconds = 0.0;
  Eigen::MatrixXd prediction;
  FitReport report;  // how the fit went, per joint for GP estimators
  // GP estimators: per joint, the learned [kernel log-parameters, log noise
  // variance] (learned_log_params); empty for the others.
  std::vector<Eigen::VectorXd> log_params;
  // A student taught by a teacher: how it and its teacher fit the training rows, and the teacher's name.
  std::optional<TeachingCheck> teaching_check;
  std::string teacher;
};
// Fits and predicts Xtest; every error becomes a message (an experiment goes on).
FitAndPredict fit_and_predict(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                              const JointTypes& joints, const Eigen::MatrixXd& Xtest);

// An experiment's estimator: a name of estimator_registry.hpp, or
// "STUDENT@TEACHER" (e.g. gip@lip): the student trained on the teacher's
// torques at states drawn from the training log's box (estimators/teacher.hpp,
// TeacherOptions' defaults and the run's seed).
struct StudentTeacherSpec {
  std::string student, teacher;  // teacher: empty without one
};
StudentTeacherSpec parse_estimator_spec(const std::string& name);

// The base options for estimator `name` (a spec as above): its name, the
// nominal robot if it needs one, the teacher if any, the seed.
EstimatorOptions options_for(const EstimatorOptions& base, const std::string& name, const RobotPrior& prior,
                             std::uint64_t seed);
// The options that change results, for config.json: the base options and,
// when an estimator has a teacher, TeacherOptions' states and rows.
nlohmann::json base_options_json(const EstimatorOptions& base, const std::vector<std::string>& estimators);
// Throws gipdyn::Error for an empty list, an unknown name or a bad teacher.
void validate_estimators(const std::vector<std::string>& estimators);
// Checks the GP and network options shared by every fit once, before the
// first fit, so that a bad option stops the experiment instead of failing every fit.
void validate_base_options(const EstimatorOptions& base);

// A progress note (ProgressEvent::message) for the application's callback.
void note(const ProgressCallback& progress, const std::string& line);

// The bookkeeping of one finished fit, whatever the experiment: counts, the
// failure log, the time estimate and the progress line. `where` prefixes the
// log line ("run 3 "), `metrics` ends the progress line ("nMSE 1e-3 ...");
// `label` names the fit in the progress lines (empty: the estimator).
void finish_fit(ExperimentOutcome& outcome, Eta& eta, const std::string& eta_key, const std::string& out,
                const std::string& where, const std::string& estimator, const FitAndPredict& f,
                const std::string& metrics, const ProgressCallback& progress, const std::string& label = "");

// Appends how one fit went to OUT/fit_reports.csv: per joint of a GP estimator
// its stop reason, evaluations, NLL, gradient norm, noise variance and jitter
// (one row with joint "all" for the other estimators). `key` names the unit
// (e.g. {{"run", "3"}}); the same key columns must be used for every call on one folder.
void record_fit_report(const std::string& out, const std::vector<std::pair<std::string, std::string>>& key,
                       const std::string& estimator, const FitAndPredict& fit);

// Warm starts between the fits of one experiment: per estimator, the
// hyperparameters one of its fits ended at, kept in OUT/warm_starts.json so
// that a resumed experiment starts its later fits from the same point.
class WarmStarts {
 public:
  // Reads OUT/warm_starts.json when it exists.
  explicit WarmStarts(std::string out);
  // Null when `estimator` has none.
  const std::vector<Eigen::VectorXd>* find(const std::string& estimator) const;
  // Keeps log_params for `estimator` (nothing when empty) and rewrites the file.
  void store(const std::string& estimator, const std::vector<Eigen::VectorXd>& log_params);

 private:
  std::string path_;
  std::map<std::string, std::vector<Eigen::VectorXd>> starts_;
};

// Draws a plot into the outcome: the PNG on success, a warning otherwise.
void plot_into(ExperimentOutcome& outcome, const std::string& kind, const std::string& input, const std::string& png);

}  // namespace gipdyn
