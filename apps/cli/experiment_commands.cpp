// `gipdyn experiment accuracy | data-efficiency | real | control | contact`: the paper's experiments and
// the applications of a learned model.
#include <cstdio>
#include <memory>

#include "exit_codes.hpp"
#include "cli_parsing.hpp"
#include "output_guard.hpp"
#include "commands.hpp"
#include "data_option.hpp"
#include "field_names.hpp"
#include "estimator_args.hpp"
#include "gipdyn/error.hpp"
#include "experiments/experiments.hpp"

namespace gipdyn::cli {
namespace {

ProgressCallback printer(bool quiet) {
  if (quiet) return {};
  return [](const ProgressEvent& e) {
    std::printf("%s\n", e.message.c_str());
    std::fflush(stdout);
  };
}

int report(const ExperimentOutcome& o, bool quiet) {
  print_warnings(o.warnings);
  if (!quiet) {
    std::printf("%d fit(s) done, %d already recorded, %d failed\n", o.units_done, o.units_skipped, o.units_failed);
    for (const auto& f : o.files) std::printf("wrote %s\n", f.c_str());
  }
  // Failed fits are recorded (as nan) so the rest of the experiment stands; say so in the exit code.
  return o.units_failed > 0 ? kExitFailure : kExitSuccess;
}

EstimatorOptions base_options(const EstimatorArgs& args) {
  EstimatorOptions o = args.build(default_estimator_name());  // the experiment's config checks the shared options
  o.robot_prior = {};
  return o;
}

using Subcommand = std::pair<CLI::App*, Command>;

// experiment accuracy (E1).
Subcommand add_accuracy(CLI::App& app, const std::shared_ptr<bool>& quiet, const std::string& estimator_help) {
  struct AccuracyArgs {
    AccuracyConfig config;
    std::string estimators = joined(paper_accuracy_estimators(), ",");
    EstimatorArgs est;
  };
  auto acc = std::make_shared<AccuracyArgs>();
  CLI::App* a = app.add_subcommand(
      "accuracy", "E1: accuracy under model bias. Per run: perturb the kinematics, simulate train and test "
                  "trajectories, fit every estimator (model-based ones on the nominal robot), record per-joint nMSE");
  a->add_option("--robot", acc->config.robot, "Nominal robot: scara, ur10, a URDF or a JSON DH file")
      ->capture_default_str();
  a->add_option("--runs", acc->config.runs, "Monte Carlo runs")->capture_default_str();
  a->add_option("--samples", acc->config.samples, "Samples per trajectory (train and test)")->capture_default_str();
  a->add_option("--seed", acc->config.seed, "Seed of the perturbations, trajectories, noise and fits")
      ->capture_default_str();
  a->add_option("--dt", acc->config.dt, "Sampling period of the trajectories (s)")->capture_default_str();
  a->add_option("--noise", acc->config.noise_std, "Torque noise standard deviation")->capture_default_str();
  a->add_option("--models", acc->estimators, estimator_help)->capture_default_str();
  a->add_option("--out", acc->config.out, "Output folder: nmse.csv, summary.md, nmse_boxplot.png")->required();
  a->add_flag("--warm-start-runs", acc->config.warm_start_runs,
              "GP: runs after the first start from the first run's learned hyperparameters (kept in "
              "OUT/warm_starts.json) instead of the data-driven start");
  a->add_option("--concurrent-runs", acc->config.concurrent_runs,
                "Runs fitted at the same time, each fit on its share of the cores (e.g. 2 on a 2-core machine: no core "
                "waits for a fit's last joint or its network). Results are the same; fit times are per share")
      ->capture_default_str();
  a->add_flag("--quiet", *quiet, "Print nothing but errors and warnings");
  acc->est.add_to(*a, false, false);  // the experiment's --seed drives everything
  return {a, [=]() -> int {
    acc->config.estimators = split_list(acc->estimators);
    acc->config.base = base_options(acc->est);
    return report(run_accuracy_experiment(acc->config, printer(*quiet)), *quiet);
  }};
}

// experiment data-efficiency (E2).
Subcommand add_data_efficiency(CLI::App& app, const std::shared_ptr<bool>& quiet, const std::string& estimator_help) {
  struct EfficiencyArgs {
    DataEfficiencyConfig config;
    std::string estimators = joined(paper_data_efficiency_estimators(), ","), sizes = "100,200,500,1000,2000,4000";
    EstimatorArgs est;
  };
  auto eff = std::make_shared<EfficiencyArgs>();
  CLI::App* d = app.add_subcommand(
      "data-efficiency", "E2: test GMSE against the number of training samples (no model bias)");
  d->add_option("--robot", eff->config.robot, "Robot: scara, ur10, a URDF or a JSON DH file")->capture_default_str();
  d->add_option("--train-samples", eff->config.train_samples, "Samples of the training trajectory")
      ->capture_default_str();
  d->add_option("--test-samples", eff->config.test_samples, "Samples of the test trajectory")->capture_default_str();
  d->add_option("--sizes", eff->sizes, "Training sizes (constant-step subsamples of the training trajectory)")
      ->capture_default_str();
  d->add_option("--runs", eff->config.runs, "Independent train/test trajectory pairs")->capture_default_str();
  d->add_option("--seed", eff->config.seed, "Seed of the trajectories, noise and fits")->capture_default_str();
  d->add_option("--dt", eff->config.dt, "Sampling period of the trajectories (s)")->capture_default_str();
  d->add_option("--noise", eff->config.noise_std, "Torque noise standard deviation")->capture_default_str();
  d->add_option("--models", eff->estimators, estimator_help)->capture_default_str();
  d->add_option("--out", eff->config.out, "Output folder: gmse.csv, summary.md, gmse.png")->required();
  d->add_flag("--quiet", *quiet, "Print nothing but errors and warnings");
  eff->est.add_to(*d, false, false);
  return {d, [=]() -> int {
    eff->config.estimators = split_list(eff->estimators);
    eff->config.sizes = parse_int_list(eff->sizes, "--sizes", "100,200,500");
    eff->config.base = base_options(eff->est);
    return report(run_data_efficiency_experiment(eff->config, printer(*quiet)), *quiet);
  }};
}

// experiment real (E3).
Subcommand add_real(CLI::App& app, const std::shared_ptr<bool>& quiet, const std::string& estimator_help) {
  struct RealArgs {
    RealRobotConfig config;
    std::string estimators, protocol, train_rows, test_rows, sizes;
    EstimatorArgs est;
  };
  auto real = std::make_shared<RealArgs>();
  CLI::App* r = app.add_subcommand(
      "real", "E3: a real robot log split into contiguous train and test rows (or alternating blocks); per-joint "
              "nMSE, bar plot, and predicted vs measured torque over a test window");
  r->add_option("--data", real->config.data, "Robot log: CSV of the documented layout, or a .mat file")
      ->required()->check(CLI::ExistingFile);
  r->add_option("--mat-variable", real->config.mat_variable,
                "Read this variable of a .mat file (columns q, qd, qdd, tau by position)");
  r->add_option("--joints", real->config.joints, "Joint types, e.g. RRRRRR (default: those the log's .json sidecar records, as simulate writes them; "
                "ur10 protocol: RRRRRR; else those of --robot; else required)");
  r->add_option("--protocol", real->protocol,
                "Reference split: ur10 (train rows 1-6340, test 6341-12349, nominal robot ur10 with friction)");
  r->add_option("--train-rows", real->train_rows, "Training rows FIRST-LAST (1-based data rows)");
  r->add_option("--test-rows", real->test_rows, "Test rows FIRST-LAST (1-based data rows)");
  r->add_option("--alternate-blocks", real->config.alternate_blocks,
                "Split the whole log into blocks of ROWS rows instead: odd blocks train, even blocks test");
  r->add_option("--nn-max-train", real->config.nn_max_train,
                "nn: at most this many training rows, a constant-step subsample (0: every training row)")
      ->capture_default_str()
      ->group(kNetworkOptions);
  r->add_option("--max-train", real->config.max_train,
                "GP estimators: at most this many training rows, a constant-step subsample")
      ->capture_default_str();
  r->add_option("--sizes", real->sizes,
                "Learning curve instead: train every estimator on constant-step subsamples of these sizes of the "
                "training rows, e.g. 100,200,500,1000,2000 (writes learning_curve.csv/.md/.png)");
  r->add_option("--repeats", real->config.repeats,
                "With --sizes: interleaved subsamples per size (shifted by a fraction of the step), for error bars")
      ->capture_default_str();
  r->add_option("--saturate", real->config.saturate,
                "Clamp the test inputs (velocities, accelerations, prismatic positions) into each estimator's training "
                "box widened by MARGIN times each input's range, e.g. 0.1 (default: off)");
  r->add_option("--plot-window", real->config.plot_window, "Test rows in the torque-over-time plot")
      ->capture_default_str();
  r->add_option("--models", real->estimators,
                estimator_help + " (default: " + joined(default_compared_estimators(false), ",") + ", plus " +
                    joined(robot_compared_estimators(), ",") + " when a robot is known)");
  r->add_option("--out", real->config.out,
                "Output folder: nmse.csv, summary.md, nmse_bar.png, torque_time.png, predictions_*.csv")
      ->required();
  r->add_flag("--quiet", *quiet, "Print nothing but errors and warnings");
  real->est.add_to(*r, true);
  return {r, [=]() -> int {
    RealRobotConfig& c = real->config;
    if (!real->train_rows.empty()) c.train_rows = parse_row_range(real->train_rows, "--train-rows");
    if (!real->test_rows.empty()) c.test_rows = parse_row_range(real->test_rows, "--test-rows");
    c.robot = real->est.robot;
    c.robot_friction = real->est.robot_friction;
    apply_protocol(real->protocol, c);
    // As train reads them: without --joints, the joint types the log's sidecar records, else --robot's.
    c.joints = joint_types_option(c.joints, c.data, c.mat_variable, c.robot).str();
    if (!real->estimators.empty()) {
      c.estimators = split_list(real->estimators);
    } else if (!c.robot.empty()) {
      c.estimators = default_compared_estimators(true);
    }
    if (!real->sizes.empty()) c.sizes = parse_int_list(real->sizes, "--sizes", "100,200,500");
    c.base = base_options(real->est);
    c.base.search.seed = real->est.seed;
    return report(run_real_robot_experiment(c, printer(*quiet)), *quiet);
  }};
}

// --contacts, --contact-size, --contact-duration and --contact-joint of an experiment that pushes its robot.
void add_contact_options(CLI::App& k, SimulatedContacts& contacts, const std::string& where) {
  k.add_option("--contacts", contacts.count, "Contacts " + where)->capture_default_str();
  k.add_option("--contact-size", contacts.size, "Each contact's torque as a fraction of its joint's torque range")
      ->capture_default_str();
  k.add_option("--contact-duration", contacts.duration, "Each contact's duration (s)")->capture_default_str();
  k.add_option("--contact-joint", contacts.joint, "The joint (1..n) every contact acts on; 0: a joint drawn for each")
      ->capture_default_str();
}

// experiment control: closed-loop tracking.
Subcommand add_control(CLI::App& app, const std::shared_ptr<bool>& quiet) {
  struct ControlArgs {
    ControlConfig config;
    std::string models;
  };
  auto ctl = std::make_shared<ControlArgs>();
  CLI::App* k = app.add_subcommand(
      "control", "Closed-loop tracking: the simulated robot follows a held-out trajectory under PD feedback plus each "
                 "model's feed-forward torque, beside PD alone and the true dynamics; RMS error and effort per joint");
  k->add_option("--robot", ctl->config.robot, "The true robot: scara, ur10, a URDF or a JSON DH file")
      ->capture_default_str();
  k->add_option("--models", ctl->models, "Comma-separated model files (any estimator) for the feed-forward torque");
  k->add_option("--seconds", ctl->config.seconds, "Length of the reference trajectory (s)")->capture_default_str();
  k->add_option("--dt", ctl->config.dt, "Control period (s)")->capture_default_str();
  k->add_option("--bandwidth", ctl->config.bandwidth,
                "PD gains: critically damped at this many rad/s on each joint's inertia")
      ->capture_default_str();
  k->add_flag("--friction", ctl->config.friction, "The true robot has viscous and Coulomb friction");
  k->add_option("--seed", ctl->config.seed,
                "Seed of the reference trajectory (use one the models were not trained on) and of the sensor noise")
      ->capture_default_str();
  k->add_option("--position-noise", ctl->config.position_noise,
                "Sensor noise: std of the positions every controller measures (rad or m); the robot moves on its "
                "true state")
      ->capture_default_str();
  k->add_option("--velocity-noise", ctl->config.velocity_noise,
                "Sensor noise: std of the measured velocities (rad/s or m/s)")
      ->capture_default_str();
  add_contact_options(*k, ctl->config.contacts,
                      "that push the robot during the run (seeded by --seed), the same for every controller; none "
                      "is told of them");
  k->add_option("--out", ctl->config.out,
                "Output folder: tracking.csv, errors.csv, summary.md, tracking.png; external.csv with --contacts")
      ->required();
  k->add_flag("--quiet", *quiet, "Print nothing but errors and warnings");
  return {k, [=]() -> int {
    if (!ctl->models.empty()) ctl->config.models = split_list(ctl->models);
    std::vector<std::pair<std::string, std::string>> inputs;
    for (const auto& m : ctl->config.models) inputs.emplace_back("--models", m);
    refuse_overwrites(inputs, {{"--out", ctl->config.out}});
    return report(run_control_experiment(ctl->config, printer(*quiet)), *quiet);
  }};
}

// experiment contact: contact detection against simulated contacts.
Subcommand add_contact(CLI::App& app, const std::shared_ptr<bool>& quiet, const std::string& estimator_help) {
  struct ContactArgs {
    ContactExperimentConfig config;
    std::string estimators = joined(ContactExperimentConfig{}.estimators, ",");
    EstimatorArgs est;
  };
  auto ct = std::make_shared<ContactArgs>();
  ContactExperimentConfig& c = ct->config;
  CLI::App* k = app.add_subcommand(
      "contact", "Contact detection: models learned on a contact-free simulated motion find contacts that act "
                 "through the robot's dynamics on a new motion (residual and momentum methods); detection rate, "
                 "delay, torque error and false alarms per model, beside the true dynamics");
  k->add_option("--robot", c.robot, "The true robot: scara, ur10, a URDF or a JSON DH file")->capture_default_str();
  k->add_option("--models", ct->estimators, estimator_help + "; the true model is always added")
      ->capture_default_str();
  k->add_option("--train-samples", c.train_samples, "Rows of the contact-free training motion")->capture_default_str();
  k->add_option("--train-dt", c.train_dt, "Sampling period of the training motion (s)")->capture_default_str();
  k->add_option("--seconds", c.seconds, "Length of the calibration, contact and contact-free motions (s)")
      ->capture_default_str();
  k->add_option("--dt", c.dt, "Their sampling period: the control period (s)")->capture_default_str();
  k->add_option("--noise", c.noise, "Torque noise standard deviation of every motion")->capture_default_str();
  add_contact_options(*k, c.contacts, "on the contact motion");
  k->add_option("--false-alarm-rate", c.detection.false_alarm_rate,
                "Probability, per row and joint, that a contact-free residual exceeds the threshold")
      ->capture_default_str();
  k->add_option("--min-duration", c.detection.min_duration, "Seconds above the threshold before a contact is flagged")
      ->capture_default_str();
  k->add_option("--seed", c.seed, "Seed of the motions, the contacts, the noise and the fits")->capture_default_str();
  k->add_option("--out", c.out, "Output folder: contacts.csv, summary.md, detection_MODEL_METHOD.csv and .png")
      ->required();
  k->add_flag("--quiet", *quiet, "Print nothing but errors and warnings");
  // lip's system is (N n) x (N n): its hyperparameters from a subsample keep the fit in minutes, as a
  // teacher's are (TeacherOptions::hyperparameter_rows); the others are conditioned on every row all the same.
  ct->est.hyperparameter_rows = TeacherOptions{}.hyperparameter_rows;
  ct->est.add_to(*k, false, false);
  return {k, [=]() -> int {
    ct->config.estimators = split_list(ct->estimators);
    ct->config.base = base_options(ct->est);
    return report(run_contact_experiment(ct->config, printer(*quiet)), *quiet);
  }};
}

}  // namespace

Command add_experiment(CLI::App& app) {
  app.require_subcommand(1);
  auto quiet = std::make_shared<bool>(false);
  const std::string estimator_help = "Comma-separated models from: " + estimator_list() +
                                     "; or STUDENT@TEACHER, e.g. gip@lip: the student trained on the teacher's torques "
                                     "at 2000 states drawn from the training log's box (train --teacher)";
  const std::vector<Subcommand> subcommands{add_accuracy(app, quiet, estimator_help),
                                            add_data_efficiency(app, quiet, estimator_help),
                                            add_real(app, quiet, estimator_help),
                                            add_control(app, quiet), add_contact(app, quiet, estimator_help)};
  return [subcommands]() -> int {
    for (const auto& [subcommand, run] : subcommands)
      if (subcommand->parsed()) return run();
    throw Error("experiment: name one of its subcommands (see gipdyn experiment --help)");
  };
}

}  // namespace gipdyn::cli
