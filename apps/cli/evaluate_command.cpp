// `gipdyn evaluate`: accuracy of a model on a CSV with measured torques, and diagnostics plots.
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "exit_codes.hpp"
#include "commands.hpp"
#include "data_option.hpp"
#include "field_names.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/training_data.hpp"
#include "reports/plots.hpp"

namespace gipdyn::cli {
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

double standard_deviation(const Eigen::VectorXd& v) { return std::sqrt((v.array() - v.mean()).square().mean()); }

// A simulated file's joint: how much its noise-free torque varies (signal) and
// how much the noise added to it does (both standard deviations).
struct TorqueSpread {
  double signal = 0.0, noise = 0.0;
};

TorqueSpread torque_spread(const Dataset& data, Eigen::Index j) {
  return {standard_deviation(data.tau_true.col(j)), standard_deviation(data.tau.col(j) - data.tau_true.col(j))};
}

// A joint whose noise-free torque varies less than the noise added to it: no
// model learns such a torque from data this noisy, and its nMSE against the
// noise-free torque is large whatever the model.
bool below_noise(const Dataset& data, Eigen::Index j) {
  if (data.tau_true.size() == 0 || data.tau.size() == 0) return false;
  const TorqueSpread spread = torque_spread(data, j);
  return spread.noise > spread.signal;
}

std::string joints_below_noise(const Dataset& data) {
  std::string out, sds;
  for (Eigen::Index j = 0; j < data.tau_true.cols(); ++j) {
    if (!below_noise(data, j)) continue;
    const TorqueSpread spread = torque_spread(data, j);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2g against %.2g", spread.signal, spread.noise);
    out += (out.empty() ? "" : ", ") + std::to_string(j + 1);
    sds += (sds.empty() ? "" : "; ") + std::string(buf);
  }
  if (out.empty()) return out;
  return "joint(s) " + out + ": the noise-free torque varies less than the noise of the measured one (std " + sds +
         "): a model learns little of it from data this noisy, so its nMSE there is large whatever the model";
}

// Joints whose nMSE is above 1, where the torque is neither constant nor below
// the noise (warned about on their own): the model predicts them worse than
// their own mean over the test rows would. On simulated logs the usual cause
// is coverage: the test motion reaches states the training motion never
// visited, whatever the estimator; on real logs also torques that differ at
// the same state (docs/results/real-robots.md).
std::string joints_worse_than_their_mean(const Accuracy& acc, const Dataset& data, const std::string& path) {
  std::string out;
  for (Eigen::Index j = 0; j < acc.nmse.size(); ++j) {
    if (!(acc.nmse(j) > 1.0) || !std::isfinite(acc.nmse(j)) || below_noise(data, j)) continue;
    char buf[48];
    std::snprintf(buf, sizeof buf, "%ld (nMSE %.3g)", static_cast<long>(j + 1), acc.nmse(j));
    out += (out.empty() ? "" : ", ") + std::string(buf);
  }
  if (out.empty()) return out;
  return "joint(s) " + out + ": the model predicts these torques worse than their own mean over " + path +
         " would. Usual causes: the test motion reaches states the training motion never visited (train on a motion "
         "that covers them), or where both visit the same state the torque differs (another payload, friction, "
         "drift); gipdyn inspect --data TRAIN --test " + path + " counts the test rows outside the training box and "
         "compares the torques where both visit the same state";
}

// The model's rigid-body terms against a robot's (KDL) at the test states.
struct PhysicsComparison {
  // Relative errors (Frobenius, inertia averaged over states); inertia_as_learned: of the rows before symmetrising.
  double gravity = 0.0, inertia = 0.0, inertia_as_learned = 0.0, coriolis = 0.0;
  Eigen::MatrixXd table;                                // g, g_true, M, M_true per state
  std::vector<std::string> header;
};

PhysicsComparison compare_physics(const Estimator& model, const RobotModel& robot, const Eigen::MatrixXd& X) {
  require_physics(model);
  const int n = model.joints().size();
  if (robot.num_joints() != n || robot.joint_types().str() != model.joints().str())
    throw Error("--physics: robot '" + robot.name() + "' has joints " + robot.joint_types().str() +
                " but the model has " + model.joints().str() + "; give the robot the data came from");
  const Eigen::MatrixXd Q = X.leftCols(n), QD = X.middleCols(n, n);
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(Q.rows(), n);
  auto rigid_body = [&](const Eigen::MatrixXd& qd, const Eigen::MatrixXd& qdd) {
    Eigen::MatrixXd S(Q.rows(), 3 * n);
    S << Q, qd, qdd;
    return inverse_dynamics(robot, S, false);
  };
  const Eigen::MatrixXd g_true = rigid_body(zero, zero);
  const Eigen::MatrixXd g = gravity(model, Q);
  const std::vector<Eigen::MatrixXd> M = inertia(model, Q);
  const std::vector<Eigen::MatrixXd> M_learned = inertia(model, Q, InertiaForm::AsLearned);
  std::vector<Eigen::MatrixXd> M_true(static_cast<size_t>(Q.rows()), Eigen::MatrixXd(n, n));
  for (int j = 0; j < n; ++j) {
    Eigen::MatrixXd unit = zero;
    unit.col(j).setOnes();
    const Eigen::MatrixXd column = rigid_body(zero, unit) - g_true;
    for (Eigen::Index r = 0; r < Q.rows(); ++r) M_true[static_cast<size_t>(r)].col(j) = column.row(r).transpose();
  }
  PhysicsComparison c;
  c.gravity = (g - g_true).norm() / std::max(g_true.norm(), 1e-300);
  for (size_t r = 0; r < M.size(); ++r) {
    const double weight = 1.0 / std::max(M_true[r].norm(), 1e-300) / static_cast<double>(Q.rows());
    c.inertia += (M[r] - M_true[r]).norm() * weight;
    c.inertia_as_learned += (M_learned[r] - M_true[r]).norm() * weight;
  }
  const Eigen::MatrixXd coriolis_true = rigid_body(QD, zero) - g_true;
  c.coriolis = (velocity_terms(model, Q, QD).coriolis - coriolis_true).norm() / std::max(coriolis_true.norm(), 1e-300);
  for (int i = 1; i <= n; ++i) c.header.push_back("g" + std::to_string(i));
  for (int i = 1; i <= n; ++i) c.header.push_back("g" + std::to_string(i) + "_true");
  for (const char* suffix : {"", "_true"})
    for (int i = 1; i <= n; ++i)
      for (int j = 1; j <= n; ++j) c.header.push_back("M" + std::to_string(i) + "_" + std::to_string(j) + suffix);
  c.table.resize(Q.rows(), 2 * n + 2 * n * n);
  for (Eigen::Index r = 0; r < Q.rows(); ++r) {
    c.table.row(r).head(n) = g.row(r);
    c.table.row(r).segment(n, n) = g_true.row(r);
    const Eigen::MatrixXd Mt = M[static_cast<size_t>(r)].transpose(), Mtt = M_true[static_cast<size_t>(r)].transpose();
    c.table.row(r).segment(2 * n, n * n) = Eigen::Map<const Eigen::RowVectorXd>(Mt.data(), n * n);  // row-major
    c.table.row(r).segment(2 * n + n * n, n * n) = Eigen::Map<const Eigen::RowVectorXd>(Mtt.data(), n * n);
  }
  return c;
}

int write_diagnostics(const std::string& dir, int window, const Estimator& model, const std::string& model_path,
                      const std::string& data_path, const Eigen::MatrixXd& target, const Eigen::MatrixXd& prediction,
                      const Accuracy& acc, const PhysicsComparison* physics) {
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
  const std::string json_path = (fs::path(dir) / "diagnostics.json").string();
  // (kind, input, png)
  std::vector<std::array<std::string, 3>> plots{{"timeseries", window_csv, "torque_time.png"},
                                                {"residuals", predictions, "residuals.png"}};
  std::vector<std::string> warnings;
  if (const InverseDynamicsModel* gp = model.gp_model()) {
    j["noise_ratio"] = noise_ratios(*gp);
    plots.push_back({"noise-ratio", json_path, "noise_ratio.png"});
  }
  if (physics) {
    j["physics_relative_error"] = {
        {"gravity", physics->gravity}, {"inertia", physics->inertia},
        {"inertia_as_learned", physics->inertia_as_learned}, {"coriolis", physics->coriolis}};
    const std::string physics_csv = (fs::path(dir) / "physics.csv").string();
    write_csv(physics_csv, physics->header, physics->table);
    plots.push_back({"physics", physics_csv, "physics.png"});
  }
  write_file_atomically(json_path, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
  for (const auto& [kind, input, png] : plots) {
    const PlotResult p = render_plot(kind, input, (fs::path(dir) / png).string());
    if (!p.ok) warnings.push_back(p.message);
  }
  print_warnings(warnings);
  if (j.contains("noise_ratio")) {
    std::printf(" learned noise / output variance:");
    for (double r : j["noise_ratio"]) std::printf(" %.3g", r);
    std::printf("\n");
  }
  std::printf("wrote diagnostics to %s\n", dir.c_str());
  return warnings.empty() ? kExitSuccess : kExitFailure;
}

}  // namespace

Command add_evaluate(CLI::App& app) {
  struct Args {
    std::string model, data, mat_variable, columns, json, plots, physics;
    int plot_window = 1000;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--model", a->model, "Model file from `gipdyn train`")->required()->check(CLI::ExistingFile);
  add_data_option(app, a->data, a->mat_variable, a->columns, "Test log: CSV with q, qd, qdd and tau columns (tau*_true used when present)");
  app.add_option("--json", a->json, "Also write the report as JSON (keys nmse, mse, gmse)");
  app.add_option("--plots", a->plots,
                 "Diagnostics folder: predicted vs measured torque over time, residual histograms and, for GP "
                 "models, the share of the output variance the model calls noise (PNG + diagnostics.json)");
  app.add_option("--physics", a->physics,
                 "Compare the model's gravity, inertia and Coriolis torque (" + joined(physics_estimator_names()) + ") with "
                 "this robot's (scara, ur10, a URDF or JSON file) at the test states: relative errors printed, "
                 "in --json, and with --plots as physics.csv and physics.png (estimated against true)");
  app.add_option("--plot-window", a->plot_window, "Rows shown in the torque-over-time plot")->capture_default_str();
  return [a]() -> int {
    refuse_overwrites({{"--model", a->model}, {"--data", a->data}}, {{"--json", a->json}});
    std::unique_ptr<PhysicsComparison> physics;
    if (a->plot_window < 1) throw Error("--plot-window must be >= 1");
    const std::unique_ptr<Estimator> model = load_estimator(a->model);
    const Dataset data = read_robot_log(a->data, a->mat_variable, model->joints(), true, "the model '" + a->model + "'", parse_log_columns(a->columns));
    const bool noise_free = data.tau_true.size() > 0;
    const Eigen::MatrixXd& target = noise_free ? data.tau_true : data.tau;
    const Eigen::MatrixXd prediction = model->predict(data.X);
    warn_about_extrapolation(*model, data.X, a->data);
    if (const InverseDynamicsModel* gp = model->gp_model()) {
      const Eigen::Index shared = count_shared_rows(gp->training_inputs(), data.X);
      if (shared > 0)
        std::fprintf(stderr,
                     "gipdyn: warning: %ld of the %ld rows of %s are training rows of this model: their error is "
                     "not a test error\n",
                     static_cast<long>(shared), static_cast<long>(data.rows()), a->data.c_str());
    }
    const Accuracy acc = compute_accuracy(target, prediction);
    if (!a->physics.empty())
      physics = std::make_unique<PhysicsComparison>(compare_physics(*model, load_robot(a->physics), data.X));
    std::printf("%ld test rows, target %s\n", static_cast<long>(data.rows()),
                noise_free ? "noise-free tau*_true" : "measured tau*");
    std::printf(" joint  MSE           nMSE\n");
    for (int j = 0; j < model->joints().size(); ++j) std::printf(" %5d  %-12.6g  %-12.6g\n", j + 1, acc.mse(j), acc.nmse(j));
    std::printf(" GMSE   %-12.6g  mean nMSE %.6g\n", acc.gmse, acc.nmse.mean());
    const std::string constant = joint_numbers(constant_columns(target, 0.0));
    if (!constant.empty())
      std::fprintf(stderr,
                   "gipdyn: warning: joint(s) %s: the target torque is constant in %s, so nMSE (MSE over its "
                   "variance) is undefined there (inf; null in JSON): judge those joints by their MSE\n",
                   constant.c_str(), a->data.c_str());
    if (noise_free && data.tau.size() > 0) {
      const std::string below = joints_below_noise(data);
      if (!below.empty()) std::fprintf(stderr, "gipdyn: warning: %s\n", below.c_str());
    }
    if (const std::string worse = joints_worse_than_their_mean(acc, data, a->data); !worse.empty())
      std::fprintf(stderr, "gipdyn: warning: %s\n", worse.c_str());
    if (physics)
      std::printf(" relative error against %s: gravity %.3g, inertia %.3g (mean over states; %.3g as learned, "
                  "before symmetrising), Coriolis %.3g\n",
                  a->physics.c_str(), physics->gravity, physics->inertia, physics->inertia_as_learned, physics->coriolis);
    if (!a->json.empty()) {
      nlohmann::json j;
      j["mse"] = std::vector<double>(acc.mse.data(), acc.mse.data() + acc.mse.size());
      j["nmse"] = std::vector<double>(acc.nmse.data(), acc.nmse.data() + acc.nmse.size());
      j["gmse"] = acc.gmse;
      j["target"] = noise_free ? "tau_true" : "tau";
      j["rows"] = data.rows();
      j["model"] = a->model;
      j["data"] = a->data;
      if (physics)
        j["physics_relative_error"] = {
            {"gravity", physics->gravity}, {"inertia", physics->inertia},
        {"inertia_as_learned", physics->inertia_as_learned}, {"coriolis", physics->coriolis}};
      write_file_atomically(a->json, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
    }
    if (!a->plots.empty())
      return write_diagnostics(a->plots, a->plot_window, *model, a->model, a->data, target, prediction, acc,
                               physics.get());
    return 0;
  };
}

}  // namespace gipdyn::cli
