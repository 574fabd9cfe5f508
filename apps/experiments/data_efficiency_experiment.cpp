#include "experiments/data_efficiency_experiment.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "reports/result_table.hpp"
#include "reports/text_format.hpp"

namespace gipdyn {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void DataEfficiencyConfig::validate() const {
  if (runs < 1) throw Error("--runs must be >= 1");
  if (train_samples < kMinTrainingRows || test_samples < 1) throw Error("--train-samples/--test-samples too small");
  if (sizes.empty()) throw Error("--sizes: give at least one training size");
  for (int s : sizes)
    if (s < kMinTrainingRows || s > train_samples)
      throw Error("--sizes: " + std::to_string(s) + " is not between " + std::to_string(kMinTrainingRows) +
                  " and --train-samples (" + std::to_string(train_samples) + ")");
  if (!(dt > 0.0)) throw Error("--dt must be > 0");
  if (!(noise_std >= 0.0)) throw Error("--noise must be >= 0");
  validate_estimators(estimators);
  validate_base_options(base);
}

nlohmann::json DataEfficiencyConfig::to_json() const {
  return {{"experiment", "data-efficiency"}, {"robot", robot}, {"train_samples", train_samples},
          {"test_samples", test_samples},    {"sizes", sizes},
          {"seed", seed},                    {"dt", dt},       {"noise", noise_std},
          {"estimators", estimators},        {"options", base_options_json(base, estimators)}};
}

ExperimentOutcome run_data_efficiency_experiment(const DataEfficiencyConfig& c, const ProgressCallback& progress) {
  c.validate();
  const RobotModel robot = load_robot(c.robot);
  const JointTypes joints = robot.joint_types();
  RobotPrior prior{std::make_shared<const RobotModel>(robot), false};
  prepare_folder(c.out, c.to_json());
  ResultTable table((fs::path(c.out) / "gmse.csv").string(), {"run", "size", "estimator", "gmse", "seconds"});
  ExperimentOutcome outcome;
  Eta eta;
  auto key = [](int r, int s, const std::string& e) {
    return std::vector<std::pair<std::string, std::string>>{
        {"run", std::to_string(r)}, {"size", std::to_string(s)}, {"estimator", e}};
  };
  for (const auto& row : table.rows()) eta.record(row[2] + "@" + row[1], std::stod(row[4]));
  for (int r = 1; r <= c.runs; ++r)
    for (int s : c.sizes)
      for (const auto& e : c.estimators)
        if (table.contains(key(r, s, e))) ++outcome.units_skipped;
        else eta.add_pending(e + "@" + std::to_string(s), 1);
  if (outcome.units_skipped > 0)
    note(progress, "resuming: " + std::to_string(outcome.units_skipped) + " fits already recorded in " + c.out);
  const auto t0 = Clock::now();
  for (int r = 1; r <= c.runs; ++r) {
    SimulationOptions so;
    so.dt = c.dt;
    so.noise_std = c.noise_std;
    so.samples = c.train_samples;
    so.seed = mix_seed(c.seed, r, 1);
    const SimulationResult train = simulate(robot, so);
    so.samples = c.test_samples;
    so.seed = mix_seed(c.seed, r, 2);
    const SimulationResult test = simulate(robot, so);
    for (int s : c.sizes) {
      // A constant-step subsample spreads the training points over the whole trajectory.
      std::vector<Eigen::Index> idx = constant_step_indices(c.train_samples, s);
      Eigen::MatrixXd X(static_cast<Eigen::Index>(idx.size()), train.X.cols()),
          Y(static_cast<Eigen::Index>(idx.size()), train.tau.cols());
      for (size_t k = 0; k < idx.size(); ++k) {
        X.row(static_cast<Eigen::Index>(k)) = train.X.row(idx[k]);
        Y.row(static_cast<Eigen::Index>(k)) = train.tau.row(idx[k]);
      }
      for (const auto& e : c.estimators) {
        if (table.contains(key(r, s, e))) continue;
        note(progress, "[run " + std::to_string(r) + "/" + std::to_string(c.runs) + ", " + std::to_string(s) +
                   " samples] " + e + ": fitting (elapsed " +
                   duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() + ")");
        const FitAndPredict f =
            fit_and_predict(options_for(c.base, e, prior, c.seed + static_cast<std::uint64_t>(r)), X, Y, joints, test.X);
        const double gmse = f.ok ? compute_accuracy(test.tau_true, f.prediction).gmse : std::nan("");
        table.append({{std::to_string(r), std::to_string(s), e, format_number(gmse), format_number(f.seconds)}});
        record_fit_report(c.out, {{"run", std::to_string(r)}, {"size", std::to_string(s)}}, e, f);
        finish_fit(outcome, eta, e + "@" + std::to_string(s), c.out,
                   "run " + std::to_string(r) + " size " + std::to_string(s) + " ", e, f, "GMSE " + sci(gmse), progress);
      }
    }
  }
  outcome.files.push_back((fs::path(c.out) / "gmse.csv").string());
  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# E2, data efficiency: " << robot.name() << " (" << joints.str() << "), no model bias\n\n";
    o << "Training subsets are constant-step subsamples of one " << c.train_samples
      << "-sample trajectory; GMSE on a " << c.test_samples << "-sample test trajectory (noise-free torque), median over "
      << c.runs << " run(s). dt " << c.dt << " s, noise std " << c.noise_std << ", seed " << c.seed << ".\n\n";
    std::vector<std::string> columns{"samples"};
    columns.insert(columns.end(), c.estimators.begin(), c.estimators.end());
    o << markdown_table_header(columns);
    for (int s : c.sizes) {
      o << "| " << s << " |";
      for (const auto& e : c.estimators) {
        std::vector<double> v;
        for (const auto& row : table.rows())
          if (row[1] == std::to_string(s) && row[2] == e) v.push_back(std::stod(row[3]));
        o << " " << sci(quantile(v, 0.5)) << " |";
      }
      o << "\n";
    }
  });
  outcome.files.push_back(summary);
  plot_into(outcome, "gmse", (fs::path(c.out) / "gmse.csv").string(), (fs::path(c.out) / "gmse.png").string());
  return outcome;
}

}  // namespace gipdyn
