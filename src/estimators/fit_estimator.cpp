#include "gipdyn/estimators/fit_estimator.hpp"

#include <chrono>
#include <cmath>
#include <new>
#include <optional>
#include <string>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/json_numbers.hpp"
#include "gipdyn/estimators/options_record.hpp"
#include "gipdyn/training_data.hpp"
#include "gipdyn/estimators/fisherian.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/neural_network_estimator.hpp"

namespace gipdyn {

void EstimatorOptions::validate() const {
  require_known_estimator(name);
  if (estimator_spec(name).identifies_chain) chain.validate();
  if (teacher) teacher->validate();
}

void check_estimator_options(const EstimatorOptions& options) {
  options.validate();
  if (estimator_needs_robot(options.name) && !options.robot_prior.robot)
    throw Error("the " + options.name + " estimator needs the nominal robot (EstimatorOptions::robot_prior)");
  switch (estimator_family(options.name)) {
    case EstimatorFamily::Gp: options.train_options().validate(); break;
    case EstimatorFamily::Lagrangian: options.lagrangian_options().validate(); break;
    case EstimatorFamily::NeuralNetwork: options.nn.validate(); break;
    case EstimatorFamily::Fisherian: break;  // the chain's options: validate()
  }
}

void EstimatorOptions::set_seed(std::uint64_t seed) {
  search.seed = seed;
  nn.seed = seed;
  chain.seed = seed;
}

SearchSettings estimator_search(const std::string& name, SearchSettings search) {
  const EstimatorSpec& spec = estimator_spec(name);
  if (!search.restarts) search.restarts = spec.restarts;
  if (!search.restart_spread) search.restart_spread = spec.restart_spread;
  if (!search.start_screening_evaluations) search.start_screening_evaluations = spec.start_screening_evaluations;
  return search;
}

TrainOptions EstimatorOptions::train_options() const {
  TrainOptions o;
  o.kernel = name;
  o.robot_prior = robot_prior;
  o.search = estimator_search(name, search);
  o.gp = gp;
  o.sparse = sparse;
  o.nll_backend = nll_backend;
  return o;
}

LagrangianOptions EstimatorOptions::lagrangian_options() const {
  // Settings of the per-joint GPs that would change a model, which LIP's one
  // coupled GP cannot honour: refused rather than ignored.
  const std::string lip = name + ": ";
  if (gp.mean != MeanKind::Zero) throw Error(lip + "GpOptions::mean must be zero (the energies have zero prior mean)");
  if (gp.prior.enabled) throw Error(lip + "GpOptions::prior is not supported; leave it off");
  if (sparse.inducing_points > 0)
    throw Error(lip + "SparseOptions::inducing_points is not supported (exact GP only); leave it at 0");
  if (nll_backend) throw Error(lip + "TrainOptions::nll_backend is not supported (one process only); leave it unset");
  LagrangianOptions o;
  o.search = estimator_search(name, search);
  o.serial_chain = serial_chain;
  o.friction = estimator_spec(name).friction;
  o.warm_start_rows = gp.warm_start_rows;
  return o;
}

namespace {

using Fit = FitResult (*)(const EstimatorOptions&, const Eigen::MatrixXd&, const Eigen::MatrixXd&, const JointTypes&,
                          const ProgressCallback&);

FitResult fit_gp(const EstimatorOptions& o, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                 const JointTypes& joints, const ProgressCallback& progress) {
  TrainResult r = train_model(X, Y, joints, o.train_options(), progress);
  FitResult result;
  result.report = std::move(r.report);
  if (result.report.ok()) result.estimator = std::make_unique<GpEstimator>(std::move(r.model));
  return result;
}

FitResult fit_lagrangian(const EstimatorOptions& o, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                         const JointTypes& joints, const ProgressCallback& progress) {
  LagrangianEstimator::FitOutcome r = LagrangianEstimator::fit(X, Y, joints, o.lagrangian_options(), progress);
  FitResult result;
  result.report = std::move(r.report);
  result.estimator = std::move(r.estimator);
  return result;
}

FitResult fit_chain(const EstimatorOptions& o, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                     const JointTypes& joints, const ProgressCallback& progress) {
  const ChainIdentification chain = identify_chain(X, Y, joints, o.chain, progress);
  FitResult result;
  result.report.seconds = chain.seconds;
  if (!chain.ok()) {
    result.report.message = chain.message;
    return result;
  }
  RobotPrior prior;
  prior.robot = std::make_shared<const RobotModel>(chain.robot);
  result.report.message = chain.brief_report();
  result.estimator =
      std::make_unique<FisherianEstimator>(FisherianEstimator::fit(prior, X, Y).identified_by(result.report.message));
  result.report.status =
      chain.status == ChainIdentificationStatus::Converged ? FitStatus::Converged : FitStatus::NotConverged;
  return result;
}

FitResult fit_fisherian(const EstimatorOptions& o, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                        const JointTypes& joints, const ProgressCallback& progress) {
  if (estimator_spec(o.name).identifies_chain) return fit_chain(o, X, Y, joints, progress);
  if (o.robot_prior.robot) require_matching_robot(o.robot_prior, joints);
  FitResult result;
  result.estimator = std::make_unique<FisherianEstimator>(FisherianEstimator::fit(o.robot_prior, X, Y));
  result.report.status = FitStatus::Converged;  // a direct least-squares solve
  return result;
}

FitResult fit_network(const EstimatorOptions& o, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                      const JointTypes& joints, const ProgressCallback& progress) {
  NeuralNetwork net = NeuralNetwork::train(X, Y, joints, o.nn, progress);
  FitResult result;
  if (!std::isfinite(net.final_loss())) {
    result.report.message = "nn: the training loss diverged (NaN); lower NeuralNetworkOptions::learning_rate";
    return result;
  }
  const long held_out = net.held_out_row_count();
  char line[200];
  if (held_out == 0) {
    result.report.status = FitStatus::Completed;  // a fixed number of epochs, with no stopping rule
    std::snprintf(line, sizeof line, "nn: %d epochs on every row (no rows held out for early stopping)",
                  net.epochs_run());
  } else {
    // Early stopping is the network's stopping rule: met where the held-out loss stopped falling before the
    // last epoch; otherwise the network may have more to learn.
    const bool stopped = net.epochs_run() < o.nn.epochs;
    result.report.status = stopped ? FitStatus::Converged : FitStatus::NotConverged;
    std::snprintf(line, sizeof line, "nn: kept epoch %d of %d, the lowest loss %.3g on the %ld rows held out%s",
                  net.kept_epoch(), net.epochs_run(), net.validation_loss(), held_out,
                  stopped ? "" : "; it still fell in the last NeuralNetworkOptions::patience epochs: more epochs may lower it");
  }
  result.report.message = line;
  result.estimator = std::make_unique<NeuralNetworkEstimator>(std::move(net));
  return result;
}

Fit fit_function(EstimatorFamily family) {
  switch (family) {
    case EstimatorFamily::Gp: return fit_gp;
    case EstimatorFamily::Lagrangian: return fit_lagrangian;
    case EstimatorFamily::Fisherian: return fit_fisherian;
    case EstimatorFamily::NeuralNetwork: return fit_network;
  }
  return fit_gp;
}

// Automatic teaching is an option the user did not ask for: a teacher or
// student that cannot start (e.g. LIP's (N n)^2 system, or an exact GP on the
// drawn states, beyond the memory left: refused by its memory check or, where
// that check underestimates, std::bad_alloc) must not stop a fit that the
// estimator alone can make. Runs start(); with automatic teaching such a
// failure is returned as its message, otherwise it propagates. Bad data or
// options throw again from the fit on the log.
template <class Start>
std::optional<std::string> could_not_start(bool automatic, Start&& start) {
  try {
    start();
  } catch (const Error& e) {
    if (!automatic) throw;
    return std::string(e.what());
  } catch (const std::bad_alloc& e) {
    if (!automatic) throw;
    return std::string(e.what());
  }
  return std::nullopt;
}

// The model file's "teacher" block (docs/model-format.md); null without a teacher.
nlohmann::json teaching_record(const EstimatorOptions& o, const FitResult& r) {
  if (!o.teacher) return nullptr;
  const TeacherOptions& t = *o.teacher;
  nlohmann::json record = {{"estimator", t.name}, {"mode", to_string(t.mode)}};
  if (r.teacher_report)
    record.update({{"states", t.states},
                   {"hyperparameter_rows", t.hyperparameter_rows},
                   {"student_hyperparameter_rows", t.student_search(o.search).hyperparameter_rows},
                   {"seed", t.seed},
                   {"label_noise_std", std::vector<double>(r.label_noise_std.data(),
                                                           r.label_noise_std.data() + r.label_noise_std.size())},
                   {"status", to_string(r.teacher_report->status)},
                   {"seconds", r.teacher_report->seconds}});
  record["outcome"] = to_string(r.teaching);
  if (r.teaching_check)  // null for a joint whose logged torque is constant
    record["log_nmse"] = {{"teacher", numbers_or_null(r.teaching_check->teacher_nmse)},
                          {"student", numbers_or_null(r.teaching_check->student_nmse)}};
  return record;
}

}  // namespace

std::optional<TeacherOptions> choose_teacher(const std::string& choice, const EstimatorOptions& options,
                                             TeacherOptions settings) {
  if (choice == kNoTeacher) return std::nullopt;
  if (choice == kAutomaticTeacher) {
    if (!automatic_teaching_applies(options)) return std::nullopt;
    settings.name = default_teacher_name();
    settings.mode = TeachingMode::Automatic;
    return settings;
  }
  if (!find_estimator_spec(choice))
    throw Error("unknown teacher '" + choice + "'; choose " + std::string(kAutomaticTeacher) + ", " + kNoTeacher +
                " or one of: " + joined(estimator_names()));
  settings.name = choice;
  settings.mode = TeachingMode::Always;
  return settings;
}

bool automatic_teaching_applies(const EstimatorOptions& options) {
  return estimator_spec(options.name).default_estimator && options.sparse.inducing_points == 0 &&
         options.gp.warm_start_rows == 0 && options.gp.mean == MeanKind::Zero && !options.robot_prior.robot &&
         !options.nll_backend;
}

bool teaches(const EstimatorOptions& options, Eigen::Index rows, int joints) {
  if (!options.teacher) return false;
  if (options.teacher->mode == TeachingMode::Automatic && !automatic_teaching_applies(options)) return false;
  return options.teacher->teaches(rows, joints);
}

Eigen::Index exact_hyperparameter_rows(const EstimatorOptions& options, Eigen::Index rows, int joints) {
  const GpOptions& gp = options.gp;
  // pp with a zero mean fits in weight space (train_model), O(rows P^2) with P parameters.
  const EstimatorSpec& spec = estimator_spec(options.name);
  const bool weight_space = spec.kernel && spec.kernel->finite_features && gp.mean == MeanKind::Zero;
  if (!is_gp_estimator(options.name) || weight_space || options.sparse.inducing_points > 0 || options.nll_backend ||
      teaches(options, rows, joints))
    return 0;
  const int subsample = options.search.hyperparameter_rows;
  return subsample > 0 && subsample < rows ? subsample : rows;
}

std::string long_exact_fit_warning(Eigen::Index rows) {
  if (rows < kLongExactFitRows) return "";
  const std::string n = std::to_string(rows);
  return "an exact GP learns its hyperparameters on " + n + " rows: every NLL evaluation factorises a " + n + " x " +
         n + " matrix, at a cost growing as rows^3 (bench/RESULTS.md times it), and a joint needs one per optimiser "
         "step";
}

std::string to_string(TeachingOutcome outcome) {
  switch (outcome) {
    case TeachingOutcome::NoTeacher: return "no teacher";
    case TeachingOutcome::Taught: return "taught";
    case TeachingOutcome::LogTooLong: return "log too long";
    case TeachingOutcome::TeacherFailed: return "teacher failed";
    case TeachingOutcome::StudentFailed: return "student failed";
    case TeachingOutcome::StudentMissedLog: return "student missed the log";
    case TeachingOutcome::NotApplicable: return "not applicable";
  }
  return "?";
}

std::string describe(TeachingOutcome outcome, const std::string& teacher_name) {
  switch (outcome) {
    case TeachingOutcome::NoTeacher: return "learned from the log";
    case TeachingOutcome::Taught: return "learned from the torques of " + teacher_name + " at states drawn from the log's box";
    case TeachingOutcome::LogTooLong:
      return "learned from the log: it is longer than TeacherOptions::automatic_max_log_values, and a long log "
             "fills more of its box by itself";
    case TeachingOutcome::TeacherFailed: return "learned from the log: the teacher " + teacher_name + " failed to fit it";
    case TeachingOutcome::StudentFailed:
      return "learned from the log: its fit on the torques of " + teacher_name + " failed";
    case TeachingOutcome::StudentMissedLog:
      return "learned from the log: the model taught by " + teacher_name +
             " fitted the logged rows far worse than its teacher (the log's states fill too little of their box, "
             "as on a real robot's log)";
    case TeachingOutcome::NotApplicable:
      return "learned from the log: automatic teaching is for the gip kernel's exact GP without a mean, nominal "
             "robot, warm start or distributed backend";
  }
  return "";
}

EstimatorOptions teacher_estimator_options(const TeacherOptions& options, const EstimatorOptions& student) {
  EstimatorOptions teacher;
  teacher.name = options.name;
  teacher.search = options.teacher_search(student.search);
  teacher.serial_chain = student.serial_chain;
  teacher.gp.keep_factor = false;
  teacher.nn.seed = student.search.seed;
  teacher.chain.seed = student.search.seed;
  teacher.chain.threads = student.search.threads;
  return teacher;
}

TeachingSet teach(const TeacherOptions& options, const EstimatorOptions& student, const Eigen::MatrixXd& X,
                  const Eigen::MatrixXd& Y, const JointTypes& joints, const ProgressCallback& progress) {
  options.validate();
  validate_training_data(X, Y, joints);
  FitResult fit = fit_estimator(teacher_estimator_options(options, student), X, Y, joints, progress);
  if (!fit.report.ok()) {
    fit.report.message = "the teacher " + options.name + " failed: " + fit.report.message;
    TeachingSet failed;
    failed.teacher_report = std::move(fit.report);
    return failed;
  }
  return label_states(options, std::move(fit.estimator), std::move(fit.report), X, Y);
}

FitResult fit_estimator(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                        const JointTypes& joints, const ProgressCallback& user_progress) {
  options.validate();
  // Events of the parts that do not know the estimator's name (the chain's
  // identification, the network's epochs) carry the fitted estimator's.
  ProgressCallback progress;
  if (user_progress)
    progress = [&](const ProgressEvent& event) {
      if (!event.estimator.empty()) return user_progress(event);
      ProgressEvent named = event;
      named.estimator = options.name;
      user_progress(named);
    };
  const auto t0 = std::chrono::steady_clock::now();
  const Fit fit = fit_function(estimator_family(options.name));
  EstimatorOptions on_log = options;
  on_log.teacher.reset();
  FitResult result;
  const bool automatic = options.teacher && options.teacher->mode == TeachingMode::Automatic;
  if (automatic && !automatic_teaching_applies(options)) {
    result = fit(on_log, X, Y, joints, progress);
    result.teaching = TeachingOutcome::NotApplicable;
  } else if (teaches(options, X.rows(), joints.size())) {
    TeachingSet lesson;
    if (const auto why = could_not_start(automatic, [&] {
          lesson = teach(*options.teacher, options, X, Y, joints, progress);
        })) {
      lesson.teacher_report.status = FitStatus::Failed;
      lesson.teacher_report.message = "the teacher " + options.teacher->name + " failed: " + *why;
    }
    if (!lesson.teacher_report.ok()) {
      if (automatic) {
        result = fit(on_log, X, Y, joints, progress);
        result.teaching = TeachingOutcome::TeacherFailed;
      } else {
        result.report.message = lesson.teacher_report.message;
      }
    } else {
      EstimatorOptions student = on_log;
      student.search = options.teacher->student_search(options.search);
      student.gp.noise_std_floor = lesson.student_noise_std_floor;
      if (const auto why = could_not_start(automatic, [&] { result = fit(student, lesson.X, lesson.Y, joints, progress); }))
        result.report.message = *why;  // result is still a default FitResult, whose status is Failed
      result.teaching = TeachingOutcome::Taught;
      result.label_noise_std = std::move(lesson.label_noise_std);
      if (result.report.ok())
        result.teaching_check = check_teaching(Y, result.label_noise_std, result.estimator->predict(X));
      if (automatic && !(result.teaching_check && result.teaching_check->passed())) {
        FitResult own = fit(on_log, X, Y, joints, progress);
        own.label_noise_std = std::move(result.label_noise_std);
        own.teaching_check = std::move(result.teaching_check);
        own.teaching = result.report.ok() ? TeachingOutcome::StudentMissedLog : TeachingOutcome::StudentFailed;
        if (!result.report.ok()) own.student_failure = result.report.message;
        result = std::move(own);
      }
    }
    result.teacher_report = std::move(lesson.teacher_report);
    result.teacher = std::move(lesson.teacher);
  } else {
    result = fit(on_log, X, Y, joints, progress);
    if (options.teacher) result.teaching = TeachingOutcome::LogTooLong;
  }
  result.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (result.estimator) {
    result.estimator->set_teaching_record(teaching_record(options, result));
    result.estimator->set_options_record(options_record(options));
  }
  if (user_progress) {
    ProgressEvent e;
    e.estimator = options.name;
    e.seconds = result.report.seconds;
    e.finished = true;
    e.message = result.report.ok() ? "fit " + to_string(result.report.status) : "failed: " + result.report.message;
    user_progress(e);
  }
  return result;
}

}  // namespace gipdyn
