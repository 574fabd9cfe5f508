#include "commands.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <iostream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

#include "estimator_args.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/experiments/plots.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/io/atomic_file.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/model_file.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/preprocess/log_preprocessing.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace gipdyn::cli {
namespace {

std::string status_word(OptimizerResult::Status s) {
  switch (s) {
    case OptimizerResult::Status::Converged: return "converged";
    case OptimizerResult::Status::MaxIterations: return "max-iter";
    case OptimizerResult::Status::Stalled: return "stalled";
    case OptimizerResult::Status::Failed: return "failed";
  }
  return "?";
}

struct TrainArgs {
  std::string data, joints, kernel = "gip", out;
  long subsample = 0;
  bool quiet = false;
  EstimatorArgs estimator;
};

}  // namespace

Command add_train(CLI::App& app) {
  auto a = std::make_shared<TrainArgs>();
  app.add_option("--data", a->data, "Training CSV with columns q1..qn, qd1..qdn, qdd1..qddn, tau1..taun")
      ->required()->check(CLI::ExistingFile);
  app.add_option("--joints", a->joints, "Joint types, one R (revolute) or P (prismatic) per joint, e.g. RRPR")
      ->required();
  app.add_option("--kernel", a->kernel,
                 "Estimator: a GP kernel (gip, gip-friction, rbf, gip+rbf, gip-friction+rbf, pp, sp) or fe, nn; "
                 "fe, pp, sp need --robot")
      ->capture_default_str();
  app.add_option("--subsample", a->subsample, "Keep this many training rows, taken with a constant step (0: all)")
      ->capture_default_str();
  a->estimator.add_to(app, true);
  app.add_option("--out", a->out, "Model file to write")->required();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    const JointTypes joints = JointTypes::parse(a->joints);
    const EstimatorOptions o = a->estimator.build(a->kernel);
    if (a->subsample < 0) throw Error("--subsample must be >= 0");

    Dataset data = read_dataset(a->data, joints, true);
    const Eigen::Index total = data.rows();
    if (a->subsample > 0) data = data.subset(constant_step_indices(total, a->subsample));
    if (!a->quiet) {
      std::printf("gipdyn train: %ld of %ld rows from %s, joints %s, estimator %s", static_cast<long>(data.rows()),
                  static_cast<long>(total), a->data.c_str(), joints.str().c_str(), o.name.c_str());
      if (is_gp_estimator(o.name))
        std::printf(", optimizer %s (max %d), %d restart(s)", a->estimator.optimizer.c_str(),
                    o.gp.optimizer.max_iterations, o.gp.restarts);
      if (o.robot_prior.robot) std::printf(", nominal robot %s", o.robot_prior.robot->name().c_str());
      std::printf("\n");
      std::fflush(stdout);
    }
    std::mutex mu;
    FitCallback progress;
    if (!a->quiet) {
      progress = [&mu](const FitProgress& p) {
        std::lock_guard<std::mutex> lock(mu);
        std::printf("  %s\n", p.message.c_str());
        std::fflush(stdout);
      };
    }
    FitResult r = fit_estimator(o, data.X, data.tau, joints, progress);
    if (!r.ok) throw Error("training failed: " + r.message);
    save_estimator(*r.estimator, a->out);
    if (!a->quiet) {
      if (!r.joint_reports.empty()) {
        std::printf("\n joint  status     NLL            evals  seconds  jitter\n");
        for (const auto& j : r.joint_reports)
          std::printf(" %5d  %-9s  %-13.6g  %5d  %7.1f  %.1e\n", j.joint + 1, status_word(j.status).c_str(), j.nll,
                      j.evaluations, j.seconds, j.jitter);
        for (const auto& j : r.joint_reports) {
          if (j.restart_nlls.size() < 2) continue;
          std::printf(" joint %d NLL over starts:", j.joint + 1);
          for (double v : j.restart_nlls) std::printf(" %.6g", v);
          std::printf("\n");
        }
      }
      std::printf("saved %s model to %s\n", r.estimator->name().c_str(), a->out.c_str());
    }
    return 0;
  };
}

Command add_predict(CLI::App& app) {
  struct Args {
    std::string model, data, out;
    bool no_std = false;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--model", a->model, "Model file from `gipdyn train`")->required()->check(CLI::ExistingFile);
  app.add_option("--data", a->data, "CSV with columns q1..qn, qd1..qdn, qdd1..qddn (others ignored)")
      ->required()->check(CLI::ExistingFile);
  app.add_option("--out", a->out,
                 "Output CSV: tau1_hat..taun_hat, and tau1_std..taun_std for GP models")->required();
  app.add_flag("--no-std", a->no_std, "Skip the standard deviations (much faster for large models)");
  return [a]() -> int {
    std::unique_ptr<Estimator> estimator = load_estimator(a->model);
    const Dataset data = read_dataset(a->data, estimator->joints(), false);
    const int n = estimator->joints().size();
    Eigen::MatrixXd mean, sd;
    std::vector<std::string> header = torque_column_names(n, "_hat");
    auto* gp = dynamic_cast<GpEstimator*>(estimator.get());
    if (a->no_std || gp == nullptr) {
      write_csv(a->out, header, estimator->predict(data.X));
    } else {
      InverseDynamicsModel& model = gp->mutable_model();
      model.enable_variance();
      model.predict(data.X, mean, &sd);
      const auto std_names = torque_column_names(n, "_std");
      header.insert(header.end(), std_names.begin(), std_names.end());
      Eigen::MatrixXd both(mean.rows(), 2 * n);
      both << mean, sd;
      write_csv(a->out, header, both);
    }
    return 0;
  };
}

namespace {

// Learned noise variance over the variance of the scaled training output, per
// joint: how much of the signal a GP model calls noise. The scaled training
// output is recovered from the fit as (K + s2 I) alpha.
std::vector<double> noise_ratios(const InverseDynamicsModel& m) {
  std::vector<double> out;
  for (int j = 0; j < m.num_joints(); ++j) {
    const GpRegressor& gp = m.joint_gp(j);
    Eigen::MatrixXd K;
    gp.kernel().cross(m.training_features(), m.training_features(), K);
    const double s2 = std::exp(gp.log_noise_variance());
    const Eigen::VectorXd y = K * gp.alpha() + s2 * gp.alpha();
    const double var = (y.array() - y.mean()).square().mean();
    out.push_back(var > 0 ? s2 / var : std::nan(""));
  }
  return out;
}

int write_diagnostics(const std::string& dir, int window, const Estimator& model, const std::string& model_path,
                      const std::string& data_path, const Eigen::MatrixXd& target, const Eigen::MatrixXd& prediction,
                      const Accuracy& acc) {
  namespace fs = std::filesystem;
  if (window < 1) throw Error("--plot-window must be >= 1");
  fs::create_directories(dir);
  const int n = model.joints().size();
  const Eigen::Index rows = target.rows(), w = std::min<Eigen::Index>(window, rows);
  std::vector<std::string> header = torque_column_names(n);
  for (const auto& c : torque_column_names(n, "_hat")) header.push_back(c);
  Eigen::MatrixXd both(rows, 2 * n);
  both << target, prediction;
  const std::string predictions = (fs::path(dir) / "predictions.csv").string();
  write_csv(predictions, header, both);
  std::vector<std::string> wheader{"row"};
  for (const auto& c : torque_column_names(n)) wheader.push_back(c);
  for (const auto& c : torque_column_names(n)) wheader.push_back(model.name() + "_" + c);
  Eigen::MatrixXd win(w, 1 + 2 * n);
  for (Eigen::Index r = 0; r < w; ++r) win(r, 0) = static_cast<double>(r + 1);
  win.middleCols(1, n) = target.topRows(w);
  win.rightCols(n) = prediction.topRows(w);
  const std::string window_csv = (fs::path(dir) / "torque_window.csv").string();
  write_csv(window_csv, wheader, win);

  nlohmann::json j;
  j["model"] = model_path;
  j["data"] = data_path;
  j["estimator"] = model.name();
  j["rows"] = rows;
  const Eigen::MatrixXd residual = target - prediction;
  const Eigen::RowVectorXd mean = residual.colwise().mean();
  const Eigen::RowVectorXd sd = ((residual.rowwise() - mean).array().square().colwise().mean()).sqrt().matrix();
  j["nmse"] = std::vector<double>(acc.nmse.data(), acc.nmse.data() + acc.nmse.size());
  j["mse"] = std::vector<double>(acc.mse.data(), acc.mse.data() + acc.mse.size());
  j["residual_mean"] = std::vector<double>(mean.data(), mean.data() + mean.size());
  j["residual_std"] = std::vector<double>(sd.data(), sd.data() + sd.size());
  std::vector<std::string> pngs{"torque_time.png", "residuals.png"};
  std::vector<std::string> warnings;
  if (const auto* gp = dynamic_cast<const GpEstimator*>(&model)) {
    j["noise_ratio"] = noise_ratios(gp->model());
    pngs.push_back("noise_ratio.png");
  }
  const std::string json_path = (fs::path(dir) / "diagnostics.json").string();
  write_file_atomically(json_path, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
  const std::vector<std::pair<std::string, std::string>> plots{
      {"timeseries", window_csv}, {"residuals", predictions}, {"noise-ratio", json_path}};
  for (size_t k = 0; k < pngs.size(); ++k) {
    const PlotResult p = render_plot(plots[k].first, plots[k].second, (fs::path(dir) / pngs[k]).string());
    if (!p.ok) warnings.push_back(p.message);
  }
  for (const auto& wmsg : warnings) std::fprintf(stderr, "gipdyn: warning: %s\n", wmsg.c_str());
  if (j.contains("noise_ratio")) {
    std::printf(" learned noise / output variance:");
    for (double r : j["noise_ratio"]) std::printf(" %.3g", r);
    std::printf("\n");
  }
  std::printf("wrote diagnostics to %s\n", dir.c_str());
  return warnings.empty() ? 0 : 2;
}

}  // namespace

Command add_evaluate(CLI::App& app) {
  struct Args {
    std::string model, data, json, plots;
    int plot_window = 1000;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--model", a->model, "Model file from `gipdyn train`")->required()->check(CLI::ExistingFile);
  app.add_option("--data", a->data, "Test CSV with q, qd, qdd and tau columns (tau*_true used when present)")
      ->required()->check(CLI::ExistingFile);
  app.add_option("--json", a->json, "Also write the report as JSON (keys nmse, mse, gmse)");
  app.add_option("--plots", a->plots,
                 "Diagnostics folder: predicted vs measured torque over time, residual histograms and, for GP "
                 "models, the share of the output variance the model calls noise (PNG + diagnostics.json)");
  app.add_option("--plot-window", a->plot_window, "Rows shown in the torque-over-time plot")->capture_default_str();
  return [a]() -> int {
    const std::unique_ptr<Estimator> model = load_estimator(a->model);
    const Dataset data = read_dataset(a->data, model->joints(), true);
    const bool noise_free = data.tau_true.size() > 0;
    const Eigen::MatrixXd& target = noise_free ? data.tau_true : data.tau;
    const Eigen::MatrixXd prediction = model->predict(data.X);
    const Accuracy acc = compute_accuracy(target, prediction);
    std::printf("%ld test rows, target %s\n", static_cast<long>(data.rows()),
                noise_free ? "noise-free tau*_true" : "measured tau*");
    std::printf(" joint  MSE           nMSE\n");
    for (int j = 0; j < model->joints().size(); ++j) std::printf(" %5d  %-12.6g  %-12.6g\n", j + 1, acc.mse(j), acc.nmse(j));
    std::printf(" GMSE   %-12.6g  mean nMSE %.6g\n", acc.gmse, acc.nmse.mean());
    if (!a->json.empty()) {
      nlohmann::json j;
      j["mse"] = std::vector<double>(acc.mse.data(), acc.mse.data() + acc.mse.size());
      j["nmse"] = std::vector<double>(acc.nmse.data(), acc.nmse.data() + acc.nmse.size());
      j["gmse"] = acc.gmse;
      j["target"] = noise_free ? "tau_true" : "tau";
      j["rows"] = data.rows();
      j["model"] = a->model;
      j["data"] = a->data;
      write_file_atomically(a->json, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
    }
    if (!a->plots.empty()) return write_diagnostics(a->plots, a->plot_window, *model, a->model, a->data, target, prediction, acc);
    return 0;
  };
}

Command add_simulate(CLI::App& app) {
  struct Args {
    std::string robot, out;
    SimulationOptions sim;
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--robot", a->robot, "scara, ur10, a URDF file or a JSON DH description (docs/robot-format.md)")
      ->required();
  app.add_option("--samples", a->sim.samples, "Number of samples")->capture_default_str();
  app.add_option("--seed", a->sim.seed, "Seed of the trajectory, the noise and the perturbation")->capture_default_str();
  app.add_option("--noise", a->sim.noise_std, "Standard deviation of the Gaussian torque noise (N m)")
      ->capture_default_str();
  app.add_option("--dt", a->sim.dt, "Sampling period in seconds")->capture_default_str();
  app.add_flag("--perturb-kinematics", a->sim.perturb_kinematics,
               "Generate the data with lengths perturbed by up to 0.05 m and angles by up to 5 deg");
  app.add_flag("--friction", a->sim.friction, "Add the robot's viscous and Coulomb friction to the torques");
  app.add_option("--out", a->out, "Output CSV (a sidecar OUT.json records how to regenerate it)")->required();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    const RobotModel robot = load_robot(a->robot);
    SimulationResult r = simulate(robot, a->sim);
    r.metadata["robot_spec"] = a->robot;
    const int n = robot.num_joints();
    std::vector<std::string> header = input_column_names(n);
    for (const char* suffix : {"", "_true"}) {
      const auto t = torque_column_names(n, suffix);
      header.insert(header.end(), t.begin(), t.end());
    }
    Eigen::MatrixXd all(r.X.rows(), 5 * n);
    all << r.X, r.tau, r.tau_true;
    write_csv_with_sidecar(a->out, header, all, r.metadata);
    const std::string sidecar = a->out + ".json";
    if (!a->quiet)
      std::printf("simulated %d samples of %s (%s, dt %g s%s%s) -> %s (+ %s)\n", a->sim.samples, robot.name().c_str(),
                  robot.joint_types().str().c_str(), a->sim.dt, a->sim.perturb_kinematics ? ", perturbed kinematics" : "",
                  a->sim.friction ? ", friction" : "", a->out.c_str(), sidecar.c_str());
    return 0;
  };
}

Command add_preprocess(CLI::App& app) {
  struct Args {
    std::string in, out;
    PreprocessOptions options;
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  app.description(
      "Turn a raw robot log into a training dataset: resample onto a uniform grid, zero-phase Butterworth\n"
      "low-pass of q, qd and tau, qd from q when the log has none, qdd from the filtered qd, optionally drop\n"
      "stretches at rest. The log needs a time column (or --log-period), q1..qn and tau1..taun (qd1..qn optional). Writes\n"
      "t, q, qd, qdd, tau columns and OUT.json, which records every step.");
  app.add_option("--in", a->in, "Raw log (CSV with a header row)")->required()->check(CLI::ExistingFile);
  app.add_option("--out", a->out, "Output dataset CSV (+ OUT.json)")->required();
  app.add_option("--time-column", a->options.time_column, "Name of the time column in seconds (default: t, else time)");
  app.add_option("--log-period", a->options.log_period,
                 "The log has no time column: its rows are this many seconds apart (e.g. 0.008 for 125 Hz)");
  app.add_option("--dt", a->options.dt, "Resampling period in seconds (default: the log's mean step, which keeps its number of samples)");
  app.add_option("--cutoff", a->options.cutoff_hz, "Low-pass cutoff in Hz (default: no filtering)");
  app.add_option("--order", a->options.filter_order, "Butterworth order of each of the two passes")
      ->capture_default_str();
  app.add_flag("--drop-rest", a->options.drop_rest,
               "Drop the stretches where every joint velocity stays below --rest-velocity for --rest-duration");
  app.add_option("--rest-velocity", a->options.rest_velocity, "Velocity under which a joint is at rest (rad/s or m/s)")
      ->capture_default_str();
  app.add_option("--rest-duration", a->options.rest_duration,
                 "Shortest stretch at rest that is dropped, in seconds (turning points are shorter)")
      ->capture_default_str();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    const PreprocessedLog log = preprocess_log(a->in, a->options);
    write_csv_with_sidecar(a->out, log.column_names(), log.table(), log.report);
    if (!a->quiet) {
      std::printf("%s: %lld rows, %d joints -> %s: %lld rows, dt %g s\n", a->in.c_str(),
                  static_cast<long long>(log.report["input_rows"].get<long long>()), log.joints(), a->out.c_str(),
                  static_cast<long long>(log.t.size()), log.report["steps"][0]["dt_s"].get<double>());
      for (const auto& s : log.report["steps"]) std::printf("  %s\n", s.dump().c_str());
      std::printf("steps recorded in %s.json\n", a->out.c_str());
    }
    return 0;
  };
}

}  // namespace gipdyn::cli
