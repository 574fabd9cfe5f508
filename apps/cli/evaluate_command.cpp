// `gipdyn evaluate`: accuracy of a model on a CSV with measured torques, and diagnostics plots.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/io/atomic_file.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
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
  if (const InverseDynamicsModel* gp = model.gp_model()) {
    j["noise_ratio"] = noise_ratios(*gp);
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
    refuse_overwriting_inputs({{"--model", a->model}, {"--data", a->data}}, {{"--json", a->json}});
    if (a->plot_window < 1) throw Error("--plot-window must be >= 1");
    const std::unique_ptr<Estimator> model = load_estimator(a->model);
    const Dataset data = read_dataset(a->data, model->joints(), true);
    const bool noise_free = data.tau_true.size() > 0;
    const Eigen::MatrixXd& target = noise_free ? data.tau_true : data.tau;
    const Eigen::MatrixXd prediction = model->predict(data.X);
    if (const InverseDynamicsModel* gp = model->gp_model()) {
      const Eigen::Index shared = count_shared_rows(gp->training_inputs(), data.X);
      if (shared > 0)
        std::fprintf(stderr,
                     "gipdyn: warning: %ld of the %ld rows of %s are training rows of this model: their error is "
                     "not a test error\n",
                     static_cast<long>(shared), static_cast<long>(data.rows()), a->data.c_str());
    }
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

}  // namespace gipdyn::cli
