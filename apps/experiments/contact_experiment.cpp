#include "experiments/contact_experiment.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <ostream>
#include <sstream>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "reports/plots.hpp"
#include "reports/text_format.hpp"

namespace fs = std::filesystem;

namespace gipdyn {

namespace {

// The name the true robot's model goes by in the tables.
constexpr const char* kTrueModel = "true";
// Seconds of the contact motion drawn in each model's plot.
constexpr double kPlotSeconds = 4.0;

int motion_rows(const ContactExperimentConfig& c) { return static_cast<int>(std::lround(c.seconds / c.dt)); }

ContactOptions detector_options(const ContactExperimentConfig& c, ContactMethod method) {
  ContactOptions o = c.detection;
  o.method = method;
  o.sample_time = c.dt;
  // The threshold a control loop runs with (ContactStream): the calibrated noise alone.
  o.predictive_variance = false;
  return o;
}

struct Row {
  std::string model, method;
  double fit_seconds = 0.0;
  ContactScore score;
  double free_alarms_per_minute = 0.0;  // flagged runs on the contact-free motion
  double exceedance_rate = 0.0;         // rows x joints above the threshold there
  Eigen::VectorXd threshold;            // per joint, the mean threshold on the contact motion
};

}  // namespace

void ContactExperimentConfig::validate() const {
  if (train_samples < 10) throw Error("--train-samples must be at least 10");
  if (!(train_dt > 0.0) || !(dt > 0.0) || !(seconds > 0.0)) throw Error("--train-dt, --dt and --seconds must be > 0");
  if (seconds / dt > 1e7) throw Error("--seconds / --dt must be at most 10^7 rows a motion");
  if (!(noise >= 0.0)) throw Error("--noise must be >= 0");
  if (contacts.count < 1) throw Error("--contacts must be at least 1");
  if (out.empty()) throw Error("--out is required: the folder for the experiment's files");
  ContactOptions probe = detection;
  probe.sample_time = dt;
  probe.validate();
}

nlohmann::json ContactExperimentConfig::to_json() const {
  return {{"experiment", "contact"},
          {"robot", robot},
          {"estimators", estimators},
          {"train_samples", train_samples},
          {"train_dt", train_dt},
          {"seconds", seconds},
          {"dt", dt},
          {"noise", noise},
          {"contacts", contacts.to_json(true)},
          {"false_alarm_rate", detection.false_alarm_rate},
          {"min_duration", detection.min_duration},
          {"momentum_gain", detection.momentum_gain},
          {"seed", seed},
          {"options", base_options_json(base, estimators)}};
}

ExperimentOutcome run_contact_experiment(const ContactExperimentConfig& c, const ProgressCallback& progress) {
  c.validate();
  validate_estimators(c.estimators);
  validate_base_options(c.base);
  const RobotModel robot = load_robot(c.robot);
  const int n = robot.num_joints();
  c.contacts.validate(n, motion_rows(c), c.dt);
  prepare_folder(c.out, c.to_json());

  // The training motion and three motions at the control rate: calibration, contacts, contact-free.
  const auto simulated = [&](int samples, double dt, std::uint64_t purpose, int contacts) {
    SimulationOptions o;
    o.samples = samples;
    o.dt = dt;
    o.noise_std = c.noise;
    o.seed = mix_seed(c.seed, 0, purpose);
    if (contacts > 0) o.contacts = c.contacts;
    return simulate(robot, o);
  };
  note(progress, "simulating the training, calibration, contact and contact-free motions ...");
  const SimulationResult train = simulated(c.train_samples, c.train_dt, 1, 0);
  const SimulationResult calibration = simulated(motion_rows(c), c.dt, 2, 0);
  const SimulationResult contact = simulated(motion_rows(c), c.dt, 3, 1);
  const SimulationResult free = simulated(motion_rows(c), c.dt, 4, 0);

  ExperimentOutcome outcome;
  std::vector<std::pair<std::string, std::unique_ptr<Estimator>>> models;
  std::vector<double> fit_seconds;
  const RobotPrior true_robot{std::make_shared<const RobotModel>(robot), false};
  std::vector<std::string> names{kTrueModel};
  names.insert(names.end(), c.estimators.begin(), c.estimators.end());
  for (size_t m = 0; m < names.size(); ++m) {
    EstimatorOptions o = names[m] == kTrueModel ? options_for(c.base, "fe", true_robot, c.seed)
                                                : options_for(c.base, names[m], true_robot, mix_seed(c.seed, m, 5));
    note(progress, "training " + names[m] + " on " + std::to_string(c.train_samples) + " rows ...");
    const auto start = std::chrono::steady_clock::now();
    FitResult r;
    try {
      r = fit_estimator(o, train.X, train.tau, robot.joint_types());
    } catch (const Error& e) {
      r.report.message = e.what();
    }
    if (!r.estimator) {
      outcome.warnings.push_back(names[m] + ": training failed: " + r.report.message);
      ++outcome.units_failed;
      continue;
    }
    fit_seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    models.emplace_back(names[m], std::move(r.estimator));
  }

  std::vector<Row> rows;
  for (size_t m = 0; m < models.size(); ++m) {
    const auto& [name, model] = models[m];
    for (ContactMethod method : {ContactMethod::Residual, ContactMethod::Momentum}) {
      if (method == ContactMethod::Momentum && !model->gives_rigid_body_terms()) continue;
      ContactDetector detector(*model, detector_options(c, method));
      detector.calibrate(calibration.X, calibration.tau);
      const ContactDetection d = detector.detect(contact.X, contact.tau);
      const ContactDetection f = detector.detect(free.X, free.tau);
      Row row;
      row.model = name;
      row.method = to_string(method);
      row.fit_seconds = fit_seconds[m];
      row.score = score_contacts(d, contact.external, c.dt);
      row.free_alarms_per_minute = 60.0 * f.contact_count.sum() / c.seconds;
      row.exceedance_rate = (f.margin.array() > 1.0).cast<double>().mean();
      row.threshold = d.threshold.colwise().mean().transpose();
      rows.push_back(row);
      note(progress, "  " + name + " (" + row.method + "): " + std::to_string(row.score.detected) + " of " +
                         std::to_string(row.score.contacts) + " contacts, " + sci(row.free_alarms_per_minute) +
                         " false alarms a minute");
      // The first seconds of the contact motion, for the plot.
      const Eigen::Index shown = std::min<Eigen::Index>(contact.X.rows(), std::lround(kPlotSeconds / c.dt));
      std::vector<std::string> header{"t"};
      for (const auto& names_of : {external_torque_column_names(n), joint_column_names("contact", n),
                                   joint_column_names("threshold", n), external_torque_column_names(n, "_true")})
        header.insert(header.end(), names_of.begin(), names_of.end());
      Eigen::MatrixXd table(shown, 1 + 4 * n);
      table.col(0) = Eigen::VectorXd::LinSpaced(shown, 0.0, static_cast<double>(shown - 1) * c.dt);
      table.middleCols(1, n) = d.external_torque.topRows(shown);
      table.middleCols(1 + n, n) = d.contact.topRows(shown).cast<double>();
      table.middleCols(1 + 2 * n, n) = d.threshold.topRows(shown);
      table.rightCols(n) = contact.external.topRows(shown);
      const std::string stem = (fs::path(c.out) / ("detection_" + name + "_" + row.method)).string();
      write_csv(stem + ".csv", header, table);
      outcome.files.push_back(stem + ".csv");
      plot_into(outcome, "contacts", stem + ".csv", stem + ".png");
      ++outcome.units_done;
    }
  }

  // The true model's threshold per method: what every learned model's is compared with.
  const auto true_threshold = [&](const std::string& method) -> const Eigen::VectorXd* {
    for (const Row& r : rows)
      if (r.model == kTrueModel && r.method == method) return &r.threshold;
    return nullptr;
  };
  const std::string csv = (fs::path(c.out) / "contacts.csv").string();
  write_file_atomically(csv, [&](std::ostream& o) {
    o << "model,method,fit_seconds,contacts,detected,detection_rate,mean_delay_ms,max_delay_ms,torque_error,"
         "false_alarms_per_minute,exceedance_rate,requested_rate,threshold_ratio\n";
    o.precision(8);
    for (const Row& r : rows) {
      const Eigen::VectorXd* truth = true_threshold(r.method);
      const double ratio = truth ? (r.threshold.array() / truth->array()).maxCoeff() : NAN;
      o << r.model << "," << r.method << "," << r.fit_seconds << "," << r.score.contacts << "," << r.score.detected
        << "," << r.score.detection_rate() << "," << 1e3 * r.score.mean_delay << "," << 1e3 * r.score.max_delay << ","
        << r.score.torque_error << "," << r.free_alarms_per_minute << "," << r.exceedance_rate << ","
        << c.detection.false_alarm_rate << "," << ratio << "\n";
    }
  });
  outcome.files.push_back(csv);

  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# Contact detection: " << robot.name() << " (" << robot.joint_types().str() << ")\n\n"
      << "Models trained on " << c.train_samples << " rows of a contact-free motion (" << c.train_dt
      << " s a row, torque noise " << c.noise << "); each detector calibrated on a contact-free " << c.seconds
      << " s motion at " << 1.0 / c.dt << " Hz, then run on a new " << c.seconds << " s motion with "
      << c.contacts.count << " contacts of " << 100.0 * c.contacts.size << " % of a joint's torque range for "
      << 1e3 * c.contacts.duration << " ms, and on a third, contact-free one. Threshold: the calibrated noise times "
      << detector_options(c, ContactMethod::Residual).threshold_factor() << " (false-alarm rate "
      << c.detection.false_alarm_rate << " a row and joint), flagged after " << 1e3 * c.detection.min_duration
      << " ms. `true` is the robot's own dynamics (fe on the true robot). Delay: from a contact's start to its "
      << "first flag; torque error: RMS over each contact over its size; exceedance: the share of contact-free rows "
      << "and joints above the threshold; threshold ratio: the largest, over joints, of the mean threshold over "
      << "the true model's.\n\n";
    o << markdown_table_header({"model", "method", "detected", "mean delay (ms)", "max delay (ms)", "torque error",
                                "false alarms / min", "exceedance", "threshold ratio", "training (s)"});
    for (const Row& r : rows) {
      const Eigen::VectorXd* truth = true_threshold(r.method);
      const double ratio = truth ? (r.threshold.array() / truth->array()).maxCoeff() : NAN;
      std::ostringstream delay, max_delay, minutes, seconds;
      delay.precision(3);
      max_delay.precision(3);
      seconds.precision(3);
      delay << 1e3 * r.score.mean_delay;
      max_delay << 1e3 * r.score.max_delay;
      seconds << r.fit_seconds;
      o << "| " << r.model << " | " << r.method << " | " << r.score.detected << " / " << r.score.contacts << " | "
        << delay.str() << " | " << max_delay.str() << " | " << sci(r.score.torque_error) << " | "
        << sci(r.free_alarms_per_minute) << " | " << sci(r.exceedance_rate) << " | " << sci(ratio) << " | "
        << seconds.str() << " |\n";
    }
    for (const auto& w : outcome.warnings) o << "\n- " << w << "\n";
  });
  outcome.files.push_back(summary);
  return outcome;
}

}  // namespace gipdyn
