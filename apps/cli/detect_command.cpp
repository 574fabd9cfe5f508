// `gipdyn detect`: contacts and external torques from a log's joint torques and a learned model.
#include <cmath>
#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "data_option.hpp"
#include "exit_codes.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/estimators/uncertainty.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/sensing/contact_detection.hpp"
#include "reports/plots.hpp"

namespace gipdyn::cli {

namespace {

// The sampling period: --dt where given, else the log's sidecar.
double sample_time_of(const CLI::Option& option, double given, const std::string& data) {
  if (option.count() > 0) return given;
  if (const std::optional<double> dt = sidecar_sample_time(data)) return *dt;
  throw Error("the sampling period of '" + data +
              "' is unknown (its sidecar " + data + ".json records none): give it with --dt SECONDS");
}

}  // namespace

Command add_detect(CLI::App& app) {
  struct Args {
    std::string model, data, mat_variable, columns, out, calibration, plot, method = "residual";
    ContactOptions options;
    bool quiet = false, noise_only = false;
  };
  auto a = std::make_shared<Args>();
  app.description(
      "Detect contacts and estimate the external torque on each joint from the measured torques and a learned\n"
      "model. residual: ext = f(q, qd, qdd) - tau, any model. momentum: the generalized-momentum observer,\n"
      "which needs no acceleration (for logs whose qdd is noisy) but a model with an inertia matrix (" +
      joined(physics_estimator_names()) + ").\n"
      "A joint is in contact once |ext| exceeds k sigma for --min-duration: sigma combines the model's predictive\n"
      "standard deviation (" + joined(uncertainty_estimator_names()) + ") with the noise it learned, or\n"
      "with the noise measured on --calibration rows; k follows from --false-alarm-rate.");
  app.add_option("--model", a->model, "Model file from `gipdyn train`")->required()->check(CLI::ExistingFile);
  add_data_option(app, a->data, a->mat_variable, a->columns,
                  "Log: CSV with columns q1..qn, qd1..qdn, qdd1..qddn, tau1..taun, consecutive rows at a "
                  "constant period; ext1_true..extn_true where the true external torque is known (simulate --contacts)");
  app.add_option("--out", a->out,
                 "Output CSV, one row per log row: t, ext1..extn (N m or N, the torque the environment applies to "
                 "each joint), contact1..contactn (0 or 1), threshold1..n, margin1..n (|ext| / threshold), and the "
                 "log's ext1_true..extn_true where it has them")
      ->required();
  app.add_option("--method", a->method, "residual or momentum")->capture_default_str();
  app.add_option("--false-alarm-rate", a->options.false_alarm_rate,
                 "Probability, per row and joint, that a contact-free residual exceeds the threshold (0, 1)")
      ->capture_default_str();
  app.add_option("--min-duration", a->options.min_duration,
                 "Seconds the residual must stay above the threshold before a contact is flagged (at least one row)")
      ->capture_default_str();
  const CLI::Option* dt =
      app.add_option("--dt", a->options.sample_time, "Sampling period of the log in seconds (default: its sidecar's)");
  app.add_option("--momentum-gain", a->options.momentum_gain,
                 "momentum: observer gain in 1/s, at most 1/dt (default: a time constant of 10 ms or two rows)");
  app.add_option("--calibration", a->calibration,
                 "A contact-free log of the same robot (not the training log: a model fits its own rows too well): "
                 "each joint's noise is measured on it. Needed for models without a predictive standard deviation")
      ->check(CLI::ExistingFile);
  app.add_flag("--noise-only", a->noise_only,
               "sigma from the noise alone (calibrated or learned), without the model's predictive standard "
               "deviation, as the C API's detector: faster on long logs and large models");
  app.add_option("--plot", a->plot, "PNG: per joint, the estimated external torque, the threshold band, flagged rows "
                                    "and the true external torque where the log has it");
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a, dt]() -> int {
    refuse_overwrites({{"--model", a->model}, {"--data", a->data}, {"--calibration", a->calibration}},
                      {{"--out", a->out}, {"--plot", a->plot}});
    a->options.method = parse_contact_method(a->method);
    a->options.predictive_variance = !a->noise_only;
    a->options.sample_time = sample_time_of(*dt, a->options.sample_time, a->data);
    a->options.validate();
    const std::unique_ptr<Estimator> model = load_estimator(a->model);
    const std::string owner = "the model '" + a->model + "'";
    const LogColumns columns = parse_log_columns(a->columns);
    const Dataset log = read_robot_log(a->data, a->mat_variable, model->joints(), true, owner, columns);
    const int n = model->joints().size();
    const Eigen::MatrixXd& truth = log.external_true;
    ContactDetector detector(*model, a->options);
    if (!a->calibration.empty()) {
      const Dataset calibration = read_robot_log(a->calibration, "", model->joints(), true, owner, columns);
      detector.calibrate(calibration.X, calibration.tau);
    }
    const ContactDetection d = detector.detect(log.X, log.tau);

    std::vector<std::string> header{"t"};
    for (const auto& names : {external_torque_column_names(n), joint_column_names("contact", n), joint_column_names("threshold", n),
                              joint_column_names("margin", n)}) {
      header.insert(header.end(), names.begin(), names.end());
    }
    Eigen::MatrixXd table(log.rows(), 1 + 4 * n + truth.cols());
    table.col(0) = Eigen::VectorXd::LinSpaced(log.rows(), 0.0, (log.rows() - 1) * a->options.sample_time);
    table.middleCols(1, n) = d.external_torque;
    table.middleCols(1 + n, n) = d.contact.cast<double>();
    table.middleCols(1 + 2 * n, n) = d.threshold;
    table.middleCols(1 + 3 * n, n) = d.margin;
    if (truth.size() > 0) {
      table.rightCols(n) = truth;
      const auto names = external_torque_column_names(n, "_true");
      header.insert(header.end(), names.begin(), names.end());
    }
    write_csv(a->out, header, table);
    if (!a->quiet) {
      std::printf("%s", d.brief_report().c_str());
      if (truth.size() > 0) {
        const ContactScore s = score_contacts(d, truth, a->options.sample_time);
        std::printf("against the log's true external torque: %d of %d contacts detected, delay %.1f ms mean and "
                    "%.1f ms max, %d false alarms (%.2f per minute of contact-free motion), torque error %.1f %% "
                    "(RMS over each contact)\n",
                    s.detected, s.contacts, 1e3 * s.mean_delay, 1e3 * s.max_delay, s.false_alarms,
                    s.false_alarms_per_minute(), 100.0 * s.torque_error);
      }
      std::printf("wrote %s\n", a->out.c_str());
    }
    if (!a->plot.empty()) {
      const PlotResult p = render_plot("contacts", a->out, a->plot);
      if (!p.ok) {
        std::fprintf(stderr, "gipdyn: warning: %s\n", p.message.c_str());
        return kExitFailure;  // the data are written
      }
      if (!a->quiet) std::printf("wrote %s\n", a->plot.c_str());
    }
    return kExitSuccess;
  };
}

}  // namespace gipdyn::cli
