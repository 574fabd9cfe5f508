#pragma once
// Fitting any estimator by name (estimator_registry.hpp) with one options
// struct, one progress interface and one result type.
#include <Eigen/Dense>
#include <memory>
#include <optional>
#include <string>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/neural_network.hpp"
#include "gipdyn/estimators/teacher.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/progress.hpp"
#include "gipdyn/robot/chain_identification.hpp"

namespace gipdyn {

struct EstimatorOptions {
  std::string name = default_estimator_name();  // a name of estimator_table()
  // How the hyperparameters are searched: the GP estimators and lip, and
  // their teacher (teacher_estimator_options).
  SearchSettings search;
  GpOptions gp;          // GP estimators
  SparseOptions sparse;  // GP estimators
  // lip, and a lip teacher (LagrangianOptions::serial_chain).
  bool serial_chain = true;
  // GP estimators: where the likelihood is computed (TrainOptions::nll_backend).
  std::shared_ptr<NllBackend> nll_backend;
  NeuralNetworkOptions nn;  // nn
  ChainIdentificationOptions chain;  // chain: the geometry search before fe
  RobotPrior robot_prior;   // the nominal robot of fe, pp, sp
  // Set: the estimator learns from a teacher's torques at states drawn from
  // the data's box instead of from the data (teacher.hpp).
  std::optional<TeacherOptions> teacher;
  // Checks this struct's own fields (the name, the teacher's options). The options of the chosen
  // estimator are checked once, by that estimator's entry point.
  void validate() const;
  // Seeds every random process of a fit: the search's starts and teacher
  // states, the network's initialisation, the chain's geometry search.
  void set_seed(std::uint64_t seed);
  // The per-joint GPs' options: this estimator's kernel and robot prior, its
  // search (estimator_search), gp, sparse, nll_backend.
  TrainOptions train_options() const;
  // lip's options: its search (estimator_search), serial_chain, and the friction of this estimator's
  // row. Throws gipdyn::Error, naming the field, for a GP setting that would
  // change the model and that LIP cannot honour (a mean, a prior, a warm
  // start, inducing points, a backend).
  LagrangianOptions lagrangian_options() const;
};

// `search` with the starts it leaves unset (SearchSettings::restarts,
// restart_spread and start_screening_evaluations) taken from the estimator table's row of `name`: the search
// a fit of that estimator runs.
SearchSettings estimator_search(const std::string& name, SearchSettings search);

// Every option a fit of `options` reads, checked before any work: the
// struct's own fields, then the chosen estimator's (train_options(),
// lagrangian_options(), nn, chain); throws gipdyn::Error naming the bad field.
// fit_estimator checks the same; front ends call it to refuse bad options
// before they print what they will do.
void check_estimator_options(const EstimatorOptions& options);

// What became of EstimatorOptions::teacher.
enum class TeachingOutcome {
  NoTeacher,         // none was asked for
  Taught,            // the estimator learned from the teacher's torques
  LogTooLong,        // TeachingMode::Automatic, a log longer than automatic_max_log_values: learned from the log
  TeacherFailed,     // TeachingMode::Automatic, the teacher's fit failed: learned from the log
  StudentFailed,     // TeachingMode::Automatic, the student's fit on the teacher's torques failed: learned from the log
  StudentMissedLog,  // TeachingMode::Automatic, the taught model failed its TeachingCheck: learned from the log
  NotApplicable,     // TeachingMode::Automatic for options automatic_teaching_applies refuses: learned from the log
};

// Where TeachingMode::Automatic teaches: the gip kernel's exact GP on one
// process, with no mean, nominal robot or warm start (docs/results/training.md, "GIP
// taught by LIP"). Elsewhere the estimator already carries what the teacher
// would add (a robot prior, a mean), or learns from a log long enough for the
// sparse or distributed fit, and the automatic teacher is not measured there.
bool automatic_teaching_applies(const EstimatorOptions& options);

// The teacher choices a front end offers beside an estimator's name.
inline constexpr const char* kAutomaticTeacher = "auto";
inline constexpr const char* kNoTeacher = "none";
// The teacher of a fit of `options`, the rule every front end follows (their
// default is kAutomaticTeacher): kNoTeacher, none; kAutomaticTeacher, the
// default teacher (default_teacher_name()) in TeachingMode::Automatic where
// automatic_teaching_applies(options), else none; an estimator's name, that
// teacher, TeachingMode::Always. The rest of the teacher's options come from
// `settings`. Throws gipdyn::Error for any other choice.
std::optional<TeacherOptions> choose_teacher(const std::string& choice, const EstimatorOptions& options,
                                             TeacherOptions settings = {});

// Whether fit_estimator fits a teacher on a log of `rows` rows and trains the
// estimator on its states: TeachingMode::Always, or Automatic where
// automatic_teaching_applies and the log is short enough (TeacherOptions::teaches);
// the taught model may still be thrown away afterwards (TeachingCheck).
bool teaches(const EstimatorOptions& options, Eigen::Index rows, int joints);

// From this many rows an exact GP's hyperparameter fit is long enough to warn
// about: every evaluation is an O(rows^3) factorisation (bench/RESULTS.md
// times them), and a joint needs one per optimiser step.
inline constexpr Eigen::Index kLongExactFitRows = 8000;

// The rows on which fit_estimator's exact GP learns its hyperparameters from
// a log of `rows` rows (all, or SearchSettings::hyperparameter_rows), or 0 where
// no O(rows^3) factorisation sets the time: not a per-joint GP, pp with a zero
// mean (it fits in weight space), a sparse or distributed fit, or one that is taught.
Eigen::Index exact_hyperparameter_rows(const EstimatorOptions& options, Eigen::Index rows, int joints);

// Said before an exact GP learns its hyperparameters on `rows` rows; "" below
// kLongExactFitRows. Front ends add what makes it fast in their own names
// (SearchSettings::hyperparameter_rows, SparseOptions::inducing_points).
std::string long_exact_fit_warning(Eigen::Index rows);

// "taught", "log too long", ...; and one line saying what it means for the model.
std::string to_string(TeachingOutcome outcome);
std::string describe(TeachingOutcome outcome, const std::string& teacher_name);

struct FitResult {
  FitReport report;  // status, time, per-joint reports for GP estimators
  std::unique_ptr<Estimator> estimator;  // null unless report.ok()
  // With EstimatorOptions::teacher: the teacher's fit and the label noise
  // (per joint) of the states the estimator learned from.
  std::optional<FitReport> teacher_report;
  std::unique_ptr<Estimator> teacher;  // the fitted teacher; null unless teacher_report->ok()
  Eigen::VectorXd label_noise_std;
  // With a teacher and a fitted student: the two's nMSE on the logged rows (its
  // warning() says when the student misses the log its teacher fits).
  std::optional<TeachingCheck> teaching_check;
  // TeachingOutcome::StudentFailed: why the fit on the teacher's torques failed.
  std::string student_failure;
  // Taught or not; with an outcome other than Taught and NoTeacher, estimator
  // learned from the log and teacher_report / teaching_check say what the
  // teaching that was not kept did.
  TeachingOutcome teaching = TeachingOutcome::NoTeacher;
};

// The options of the teacher `options` names for `student`: the student's
// search (TeacherOptions::teacher_search; its seed and threads also seed and
// share out the network's and the chain's own searches) and what the student
// knows of the log (serial_chain: its joints run base to tip). Nothing of the
// student's model: its kernel, mean, prior, sparse or distributed fit and
// nominal robot are the library's defaults; and no kept factor, since the
// teacher only predicts means.
EstimatorOptions teacher_estimator_options(const TeacherOptions& options, const EstimatorOptions& student);

// Fits the teacher of `options` on (X, Y) (teacher_estimator_options) and labels TeacherOptions::states
// drawn states (label_states). Bad options or data throw gipdyn::Error before
// any work; a teacher that fails to fit is reported in
// TeachingSet::teacher_report, whose message then names the teacher ("the
// teacher lip failed: ..."; X, Y empty).
TeachingSet teach(const TeacherOptions& options, const EstimatorOptions& student, const Eigen::MatrixXd& X,
                  const Eigen::MatrixXd& Y, const JointTypes& joints, const ProgressCallback& progress = {});

// Fits the named estimator and sets its teaching record (Estimator::teaching_record) (with a teacher: the teacher, then the estimator on
// its labelled states; a teacher or student that fails, or cannot start for
// want of memory, fails the fit, unless TeachingMode::Automatic, which then
// learns from the log, as it does for options automatic_teaching_applies
// refuses). Bad options or data throw gipdyn::Error before any work; a
// numerical failure is reported in FitResult::report. progress may be
// called from worker threads; it ends with one finished event for the whole fit.
FitResult fit_estimator(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                        const JointTypes& joints, const ProgressCallback& progress = {});

}  // namespace gipdyn
