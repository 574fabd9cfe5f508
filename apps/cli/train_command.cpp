// `gipdyn train`: fit any estimator on a CSV and write its model file.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <unistd.h>
#include <string>

#include "commands.hpp"
#include "data_option.hpp"
#include "distributed_run.hpp"
#include "output_guard.hpp"
#include "estimator_args.hpp"
#include "field_names.hpp"
#include "long_fit_notice.hpp"
#include "progress_display.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/model_selection.hpp"
#include "gipdyn/estimators/presets.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/io/detail/json_numbers.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "gipdyn/training_data.hpp"
#include "reports/text_format.hpp"

namespace gipdyn::cli {
namespace {

struct TrainArgs {
  std::string data, mat_variable, columns, joints, model = default_estimator_name(), out, preset, teacher = kAutomaticTeacher, teacher_out;
  long subsample = 0;
  int teacher_states = TeacherOptions{}.states, teacher_hyperparameter_rows = TeacherOptions{}.hyperparameter_rows,
      student_hyperparameter_rows = TeacherOptions{}.student_hyperparameter_rows;
  bool quiet = false, distributed = false;
  EstimatorArgs estimator;
};

// Where --teacher auto teaches (the library's automatic_teaching_applies), in train's flags.
const char* const kAutomaticTeachingConditions =
    "(--model gip alone, without --inducing, --warm-start-rows, --mean, --robot or --distributed)";

// The options, the teacher and the rows of a training, or the first error (thrown).
struct TrainPlan {
  EstimatorOptions o;
  Dataset data;
  // Printed after training, so that an error stays the only line on stderr when the fit cannot start.
  std::vector<std::string> data_warnings;
  Eigen::Index total = 0;  // the log's rows, before --subsample
  // --model auto: the estimator is chosen by evidence (fit_selected_estimator); o holds the shared search options.
  bool select = false;
  TeacherOptions teacher_settings;
};

// --model auto: the options that name one model or one way of fitting, which the choice by evidence makes itself.
void refuse_options_beside_a_choice(const CLI::App& app) {
  for (const char* name : {"--preset", "--teacher", "--teacher-out", "--robot", "--inducing", "--distributed",
                           "--mean", "--warm-start-rows"})
    if (app.count(name) > 0)
      throw Error(std::string(name) + " chooses part of the model, and --model " + kAutomaticEstimator +
                  " chooses the whole model by evidence: name a model with --model to use " + name +
                  ", or drop it");
}

void plan_training(TrainArgs& a, const CLI::App& app, DistributedRun* mpi, const JointTypes& joints,
                   const LogColumns& columns, TrainPlan& plan) {
  EstimatorOptions& o = plan.o;
  Dataset& data = plan.data;
  std::vector<std::string>& data_warnings = plan.data_warnings;
  refuse_overwrites({{"--data", a.data}, {"--robot", a.estimator.robot}},
                    {{"--out", a.out}, {"--teacher-out", a.teacher_out}});
  plan.select = a.model == kAutomaticEstimator;
  if (plan.select) refuse_options_beside_a_choice(app);
  o = a.preset.empty()
          ? a.estimator.build(plan.select ? default_estimator_name() : a.model)
          : a.estimator.build_over(preset_options(a.preset), app, a.model, app.count("--model") > 0);
  if (a.subsample < 0) throw Error("--subsample must be >= 0");
  if (mpi) {
    if (!is_gp_estimator(o.name))
      throw Error("--distributed trains the exact GP of a GP kernel (" +
                  joined(kernel_names()) +
                  "), not '" + o.name + "'");
    o.nll_backend = mpi->backend();
  }
  const bool automatic = a.teacher == kAutomaticTeacher;
  TeacherOptions settings;
  settings.states = a.teacher_states;
  settings.hyperparameter_rows = a.teacher_hyperparameter_rows;
  settings.student_hyperparameter_rows = a.student_hyperparameter_rows;
  settings.seed = o.search.seed;
  plan.teacher_settings = settings;
  o.teacher = choose_teacher(plan.select ? kNoTeacher : a.teacher, o, settings);
  const bool teaches = o.teacher.has_value();
  // The teacher's options where no teacher teaches: left over beside --teacher none, but a
  // misunderstanding beside the default, which the user may have expected to teach.
  if (!teaches && !a.teacher_out.empty())
    throw Error(std::string("--teacher-out writes a teacher's model, and ") +
                (automatic ? "--teacher auto does not teach " + o.name + " with these options " +
                                 kAutomaticTeachingConditions
                           : std::string("--teacher none trains without one")) +
                ": name a teacher (e.g. --teacher lip), or drop --teacher-out");
  if (!teaches && !plan.select)
    for (const char* name : {"--teacher-states", "--teacher-hyperparameter-rows", "--student-hyperparameter-rows"}) {
      if (app.count(name) == 0) continue;
      if (!automatic) {
        data_warnings.push_back(std::string(name) + " has no effect: --teacher none trains without a teacher");
        continue;
      }
      throw Error(std::string(name) + " sets up a teacher, and --teacher auto does not teach " + o.name +
                  " with these options " + kAutomaticTeachingConditions +
                  ": name a teacher (e.g. --teacher lip), or drop " + name);
    }
  if (teaches && mpi)
    throw Error("--teacher is not distributed: train without --distributed, or without --teacher");
  check_estimator_options(o);
  if (!a.preset.empty() && app.count("--subsample") == 0) a.subsample = preset_max_training_rows(a.preset);
  data = read_robot_log(a.data, a.mat_variable, joints, true, "", columns);
  for (const auto& w : training_input_warnings(data.X, joints, a.data)) data_warnings.push_back(w);
  plan.total = data.rows();
  if (a.subsample > 0) data = data.subset(constant_step_indices(plan.total, a.subsample));
}

// What train is about to do, before the minutes are spent.
void print_plan(const TrainArgs& a, const TrainPlan& plan, const DistributedRun* mpi, const JointTypes& joints) {
  const EstimatorOptions& o = plan.o;
  const Dataset& data = plan.data;
  const Eigen::Index total = plan.total;
  if (plan.select) {
    const std::vector<std::string> candidates = selection_candidates();
    std::printf("gipdyn train: %ld of %ld rows from %s, joints %s, estimator chosen by evidence among %s: each "
                "fitted on the first %.0f %% of the rows and scored on the rest, the best refitted on every row\n",
                static_cast<long>(data.rows()), static_cast<long>(total), a.data.c_str(), joints.str().c_str(),
                joined(candidates).c_str(), 100.0 * (1.0 - SelectionOptions{}.held_out_fraction));
    std::fflush(stdout);
    return;
  }
  std::printf("gipdyn train: %ld of %ld rows from %s, joints %s, estimator %s", static_cast<long>(data.rows()),
              static_cast<long>(total), a.data.c_str(), joints.str().c_str(), o.name.c_str());
  if (!a.preset.empty()) std::printf(" (preset %s)", a.preset.c_str());
  if (is_kernel_estimator(o.name))
    std::printf(", optimizer %s (max %d), %d restart(s)", a.estimator.optimizer.c_str(),
                o.search.optimizer.max_iterations, estimator_search(o.name, o.search).restart_count());
  if (is_kernel_estimator(o.name) && o.sparse.inducing_points > 0)
    std::printf(", sparse GP with %d inducing rows", o.sparse.inducing_points);
  if (o.robot_prior.robot) std::printf(", nominal robot %s", o.robot_prior.robot->name().c_str());
  if (mpi) std::printf(", distributed over %s", o.nll_backend->describe().c_str());
  if (o.teacher && !o.teacher->teaches(data.rows(), joints.size())) {
    std::printf(", no teacher (%ld values: longer than the %ld that --teacher auto teaches)",
                static_cast<long>(data.rows() * joints.size()), o.teacher->automatic_max_log_values);
  } else if (o.teacher) {
    const int student_rows = o.teacher->student_search(o.search).hyperparameter_rows;
    std::printf(", taught by %s (hyperparameters on %s rows) at %d states drawn from the log's box "
                "(the student's hyperparameters on %s of them)",
                o.teacher->name.c_str(),
                o.teacher->hyperparameter_rows > 0 && o.teacher->hyperparameter_rows < data.rows()
                    ? std::to_string(o.teacher->hyperparameter_rows).c_str()
                    : "all",
                o.teacher->states,
                student_rows > 0 && student_rows < o.teacher->states ? std::to_string(student_rows).c_str() : "all");
    if (o.teacher->mode == TeachingMode::Automatic)
      std::printf("; kept if it fits the log as %s does, else %s learns from the log (--teacher auto; none: no "
                  "teacher)",
                  o.teacher->name.c_str(), o.name.c_str());
  }
  std::printf("\n");
  if (const std::string note = long_exact_fit_note(exact_hyperparameter_rows(o, data.rows(), joints.size()));
      !note.empty())
    std::printf("  %s\n", note.c_str());
  // Where the log is not a simulated one, it may be a robot's: there the taught model is usually
  // thrown away after the teacher's minutes, and gip alone runs away from the training motions
  // (docs/results/real-robots.md). Say so before the minutes are spent.
  if (a.preset.empty() && estimator_spec(o.name).default_estimator &&
      sidecar_generator(a.data) != std::optional<std::string>(kSimulationGenerator)) {
    const char* const recommendation =
        "  note: on a real robot's log, --preset real is the recommendation (docs/guide/real-robot-log.md): there";
    const bool taught = o.teacher && o.teacher->teaches(data.rows(), joints.size());
    if (taught && o.teacher->mode == TeachingMode::Automatic)
      std::printf("%s the model %s teaches is usually thrown away, after %s's fit\n",
                  recommendation, o.teacher->name.c_str(), o.teacher->name.c_str());
    else if (!taught)
      std::printf("%s %s alone extrapolates its polynomial away from the training motions (docs/results/real-robots.md "
                  "compares it with --preset real on the shared UR10 log)\n",
                  recommendation, o.name.c_str());
  }
  std::fflush(stdout);
}

// The fit's reports, notes and warnings.
void print_outcome(const TrainArgs& a, const TrainPlan& plan, const FitResult& r, bool teacher_written) {
  const EstimatorOptions& o = plan.o;
  const std::vector<std::string>& data_warnings = plan.data_warnings;
  if (r.teaching == TeachingOutcome::TeacherFailed) {
    std::printf("\n%s\n%s %s:", r.teacher_report->message.c_str(), o.name.c_str(),
                describe(r.teaching, o.teacher->name).c_str());
  } else if (r.teacher_report) {
    std::printf("\nteacher %s: %s", o.teacher->name.c_str(), r.teacher_report->brief_report().c_str());
    std::printf("label noise (the teacher's RMS residual on the log, the student's noise floor), per joint:");
    for (Eigen::Index j = 0; j < r.label_noise_std.size(); ++j) std::printf(" %.3g", r.label_noise_std(j));
    if (r.teaching == TeachingOutcome::Taught)
      std::printf("\nstudent %s on the teacher's torques (its time includes the teacher's):", o.name.c_str());
    else if (r.teaching == TeachingOutcome::StudentFailed)
      std::printf("\n%s %s (%s); its time includes the teacher's:", o.name.c_str(),
                  describe(r.teaching, o.teacher->name).c_str(), r.student_failure.c_str());
    else
      std::printf("\n%s %s; its time includes the teacher's:", o.name.c_str(),
                  describe(r.teaching, o.teacher->name).c_str());
  } else if (o.teacher) {
    std::printf("\n%s %s:", o.name.c_str(), describe(r.teaching, o.teacher->name).c_str());
  }
  std::printf("\n%s", r.report.brief_report().c_str());
  if (r.teaching_check) {
    std::printf("nMSE on the logged rows, per joint, teacher / %s:",
                r.teaching == TeachingOutcome::Taught ? "student" : "the taught model, not kept");
    for (Eigen::Index j = 0; j < r.teaching_check->student_nmse.size(); ++j)
      std::printf(" %.3g/%.3g", r.teaching_check->teacher_nmse(j), r.teaching_check->student_nmse(j));
    std::printf("\n");
    const std::vector<int> ahead = r.teaching_check->joints_teacher_far_ahead();
    if (r.teaching == TeachingOutcome::Taught && !ahead.empty()) {
      std::string joints_text;
      for (int j : ahead) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "%s%d (%.3g against %.3g)", joints_text.empty() ? "" : ", ", j + 1,
                      r.teaching_check->teacher_nmse(j), r.teaching_check->student_nmse(j));
        joints_text += buf;
      }
      std::printf("note: the teacher %s fits the logged rows of joint %s ten times better or more than its "
                  "student: there it is likely the more accurate model (%s; "
                  "docs/training.md)\n",
                  o.teacher->name.c_str(), joints_text.c_str(),
                  teacher_written ? ("written to " + a.teacher_out).c_str()
                                  : "--teacher-out FILE writes it beside the student");
    }
  }
  if (teacher_written) std::printf("saved the teacher's %s model to %s\n", r.teacher->name().c_str(), a.teacher_out.c_str());
  const InverseDynamicsModel* gp = r.estimator->gp_model();
  if (gp && gp->is_sparse())
    std::printf("sparse GP: %d inducing rows for %ld training rows%s\n", gp->num_training_samples(),
                static_cast<long>(gp->num_data_rows()),
                gp->num_training_samples() < o.sparse.inducing_points
                    ? " (fewer than asked: the rest would add no direction to the kernel's feature space)"
                    : "");
  std::printf("saved %s model to %s\n", r.estimator->name().c_str(), a.out.c_str());
  std::fflush(stdout);
  print_warnings(data_warnings);
  if (r.teacher_report && r.teaching == TeachingOutcome::Taught) {  // a teaching not kept has no say in the model
    std::vector<std::string> lines = r.teacher_report->warnings();
    for (auto& w : lines) w = "teacher " + o.teacher->name + ": " + w;
    print_warnings(lines);
  }
  print_warnings(r.report.warnings());
  if (r.teaching_check && r.teaching == TeachingOutcome::Taught) {
    const std::string w = r.teaching_check->warning(o.teacher->name);
    if (!w.empty()) print_warnings({w});
  }
}

int run_train(TrainArgs& a, const CLI::App& app) {
  std::unique_ptr<DistributedRun> mpi;
  if (a.distributed) mpi = std::make_unique<DistributedRun>();
  if (mpi && !mpi->is_root()) a.quiet = true;
  const LogColumns columns = parse_log_columns(a.columns);
  const JointTypes joints = joint_types_option(a.joints, a.data, a.mat_variable, a.estimator.robot, columns);
  TrainPlan plan;
  std::string setup_error;
  try {
    plan_training(a, app, mpi.get(), joints, columns, plan);
  } catch (const std::exception& e) {
    if (!mpi) throw;
    setup_error = e.what();
  }
  if (mpi) mpi->agree(setup_error);
  if (!a.quiet) print_plan(a, plan, mpi.get(), joints);
  const EstimatorOptions& o = plan.o;
  const Dataset& data = plan.data;
  std::optional<Selection> selection;
  std::mutex mu;
  ProgressCallback progress;
  LongFitNotice notice(joints.size(), joints_trained_at_once(o.train_options(), data.rows(), joints.size()));
  ProgressDisplay display(stdout, joints.size(), isatty(fileno(stdout)) != 0);
  if (!a.quiet) {
    progress = [&mu, &notice, &display, sparse = o.sparse.inducing_points > 0](const ProgressEvent& e) {
      std::string note;
      {
        std::lock_guard<std::mutex> lock(mu);
        if (!sparse) note = notice.observe(e);
      }
      if (!note.empty()) display.note(note);
      display.observe(e);
    };
  }
  FitResult r;
  try {
    if (plan.select) {
      SelectionResult chosen =
          fit_selected_estimator(o, SelectionOptions{}, data.X, data.tau, joints, plan.teacher_settings, progress);
      selection = std::move(chosen.selection);
      r = std::move(chosen.fit);
      plan.o = std::move(chosen.options);  // the chosen candidate's, which the outcome describes
      // Per joint: several models, each with its own teaching record in the model file.
      if (selection->per_joint()) plan.o.teacher.reset();
    } else {
      r = fit_estimator(o, data.X, data.tau, joints, progress);
    }
  } catch (...) {
    if (!mpi) throw;
    mpi->fail(std::current_exception());
  }
  // A distributed training's status is the same on every process: the first one reports it and writes.
  if (mpi && !mpi->is_root()) {
    if (!r.report.ok()) throw ExitQuietly();
    return 0;
  }
  display.finish();
  if (selection && !a.quiet) std::printf("\n%s", selection->brief_report().c_str());
  if (!r.report.ok()) throw Error("training failed: " + r.report.message);
  save_estimator(*r.estimator, a.out);
  // Whatever became of the taught model: the teacher's fit is the user's to keep.
  const bool teacher_written = r.teacher && !a.teacher_out.empty();
  if (teacher_written) save_estimator(*r.teacher, a.teacher_out);
  // Even with --quiet: an output the user asked for is missing.
  if (!a.teacher_out.empty() && !r.teacher)
    print_warnings({"no teacher model written to " + a.teacher_out + ": " +
                    (r.teaching == TeachingOutcome::LogTooLong
                         ? "the log is longer than --teacher auto teaches, so no teacher was fitted"
                         : "the teacher " + o.teacher->name + " failed to fit the log")});
  if (!a.quiet) print_outcome(a, plan, r, teacher_written);
  return 0;
}

}  // namespace

// train's own heading of --help, beside the estimators' (estimator_args.hpp).
const char* const kTeacherOptions = "Teacher (GIP taught by LIP: train's default where it fits the log)";

Command add_train(CLI::App& app) {
  auto a = std::make_shared<TrainArgs>();
  add_data_option(app, a->data, a->mat_variable, a->columns, "Training log: CSV with columns q1..qn, qd1..qdn, qdd1..qddn, tau1..taun");
  app.add_option("--joints", a->joints, "Joint types, one R (revolute) or P (prismatic) per joint, e.g. RRPR (default: those the log's .json sidecar records, as simulate writes them; else those of --robot; else required)");
  app.add_option("--model", a->model,
                 std::string("Model, one of those listed under Models below (docs/choosing-a-model.md says "
                             "which for which log), or ") + kAutomaticEstimator +
                     ": choose among " + joined(selection_candidates()) +
                     " by evidence, each fitted on the log's earlier rows and scored on its last " +
                     std::to_string(static_cast<int>(100.0 * SelectionOptions{}.held_out_fraction)) +
                     " %, the best refitted on every row (per joint, where another candidate predicted a joint "
                     "more than twice as well)")
      ->capture_default_str();
  app.footer(estimator_table_text());
  app.add_option("--subsample", a->subsample,
                 "Keep this many training rows, taken with a constant step (0: all, or the --preset's limit)")
      ->capture_default_str();
  app.add_option("--preset", a->preset,
                 "Start from a named set of options; options given explicitly override it: " + preset_list() +
                     "; real is for logs of real robots (docs/guide/real-robot-log.md)");
  app.add_option(
      "--teacher", a->teacher,
      "Learn from a teacher instead of the log: fit this estimator (e.g. lip) on the log, then train --model on "
      "its torques at --teacher-states states drawn uniformly from the log's box. On one short motion, --teacher "
      "lip gives a GIP model that extrapolates like LIP and answers like GIP (docs/training.md, \"Learning "
      "from a teacher\"). auto: lip " + std::string(kAutomaticTeachingConditions) + " on a log of at most " +
          std::to_string(TeacherOptions{}.automatic_max_log_values) +
          " values (rows x joints), kept only if the taught model fits the log as LIP does (on a real robot's log "
          "it does not: then gip learns from the log itself, after LIP's minutes); none: no teacher")
      ->capture_default_str()
      ->group(kTeacherOptions);
  app.add_option("--teacher-states", a->teacher_states,
                 "Where a teacher teaches (--teacher; auto by default): states drawn from the log's box (each of "
                 "q, qd, qdd between its smallest and largest logged value), the student's training rows; --seed "
                 "draws them")
      ->capture_default_str()
      ->group(kTeacherOptions);
  app.add_option("--teacher-hyperparameter-rows", a->teacher_hyperparameter_rows,
                 "Where a teacher teaches (--teacher; auto by default): the teacher learns its hyperparameters on "
                 "a constant-step subsample of this many logged rows, then is conditioned on every row; 0: all rows")
      ->capture_default_str()
      ->group(kTeacherOptions);
  app.add_option("--student-hyperparameter-rows", a->student_hyperparameter_rows,
                 "Where a teacher teaches (--teacher; auto by default): the student learns its hyperparameters on "
                 "a constant-step subsample of this many drawn states (independent draws over the box: a few "
                 "hundred inform the NLL as well as thousands), then is conditioned on every state; 0: all states. "
                 "--hyperparameter-rows, if given, wins")
      ->capture_default_str()
      ->group(kTeacherOptions);
  app.add_option("--teacher-out", a->teacher_out,
                 "Where a teacher teaches (--teacher; auto by default): also write the teacher's model (e.g. lip) "
                 "to this file, whatever became of the taught one. train notes the joints on which the teacher "
                 "fits the log ten times better than its student: there it is likely the more accurate model "
                 "(docs/training.md)")
      ->group(kTeacherOptions);
  a->estimator.add_to(app, true);
  app.add_option("--out", a->out, "Model file to write")->required();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  app.add_flag("--distributed", a->distributed,
               "Spread each joint's exact GP over MPI processes (ScaLAPACK): run `mpirun -np P gipdyn train "
               "--distributed ...`, every process with the same options and data; the first one prints and writes "
               "--out (docs/distributed.md)");
  return [a, &app]() -> int { return run_train(*a, app); };
}

}  // namespace gipdyn::cli
