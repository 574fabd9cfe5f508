#include "experiments/accuracy_experiment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "reports/result_table.hpp"
#include "reports/text_format.hpp"

namespace gipdyn {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void AccuracyConfig::validate() const {
  if (runs < 1) throw Error("--runs must be >= 1");
  if (concurrent_runs < 1) throw Error("--concurrent-runs must be >= 1");
  if (samples < kMinTrainingRows) throw Error("--samples must be >= " + std::to_string(kMinTrainingRows));
  if (!(dt > 0.0)) throw Error("--dt must be > 0");
  if (!(noise_std >= 0.0)) throw Error("--noise must be >= 0");
  validate_estimators(estimators);
  validate_base_options(base);
}

nlohmann::json AccuracyConfig::to_json() const {
  // Not `runs`: an experiment may be extended with more runs.
  nlohmann::json j = {{"experiment", "accuracy"}, {"robot", robot},   {"samples", samples},
                      {"seed", seed},             {"dt", dt},         {"noise", noise_std},  {"estimators", estimators},
                      {"options", base_options_json(base, estimators)}};
  // Only when on, so that the folders of earlier versions (cold starts) still resume.
  if (warm_start_runs) j["warm_start_runs"] = true;
  return j;
}

namespace {

// summary.md: median and quartiles per estimator and joint; its path.
std::string write_summary(const AccuracyConfig& c, const RobotModel& nominal, const ResultTable& table) {
  const JointTypes joints = nominal.joint_types();
  const int n = joints.size();
  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# E1, accuracy under model bias: " << nominal.name() << " (" << joints.str() << ")\n\n";
    o << c.runs << " runs, " << c.samples << " training and " << c.samples << " test samples per run, dt " << c.dt
      << " s, noise std " << c.noise_std << ", seed " << c.seed
      << ". nMSE on the noise-free test torque; median [first quartile, third quartile] over runs.\n\n";
    std::vector<std::string> columns{"estimator"};
    for (const std::string& c : joint_columns(n)) columns.push_back(c);
    columns.insert(columns.end(), {"runs < 1 % on every joint", "mean fit time"});
    o << markdown_table_header(columns);
    for (const auto& e : c.estimators) {
      o << "| " << e << " |";
      std::map<std::string, bool> below;
      double seconds = 0.0;
      int fits = 0;
      for (int j = 1; j <= n; ++j) {
        std::vector<double> v;
        for (const auto& row : table.rows())
          if (row[1] == e && row[2] == std::to_string(j)) {
            const double x = std::stod(row[3]);
            v.push_back(x);
            below[row[0]] = (below.count(row[0]) ? below[row[0]] : true) && x < 0.01;
            if (j == 1) {
              seconds += std::stod(row[4]);
              ++fits;
            }
          }
        o << " " << sci(quantile(v, 0.5)) << " [" << sci(quantile(v, 0.25)) << ", " << sci(quantile(v, 0.75)) << "] |";
      }
      int good = 0;
      for (const auto& [run, ok] : below) good += ok;
      o << " " << good << "/" << below.size() << " | " << (fits ? duration(seconds / fits) : "n/a") << " |\n";
    }
  });
  return summary;
}

}  // namespace

ExperimentOutcome run_accuracy_experiment(const AccuracyConfig& c, const ProgressCallback& progress) {
  c.validate();
  const RobotModel nominal = load_robot(c.robot);
  const JointTypes joints = nominal.joint_types();
  const int n = joints.size();
  RobotPrior prior{std::make_shared<const RobotModel>(nominal), false};
  prepare_folder(c.out, c.to_json());
  ResultTable table((fs::path(c.out) / "nmse.csv").string(), {"run", "estimator", "joint", "nmse", "seconds"});
  ExperimentOutcome outcome;
  Eta eta;
  for (const auto& row : table.rows())
    if (row[2] == "1") eta.record(row[1], std::stod(row[4]));
  for (int r = 1; r <= c.runs; ++r)
    for (const auto& e : c.estimators)
      if (!table.contains({{"run", std::to_string(r)}, {"estimator", e}})) eta.add_pending(e, 1);
      else ++outcome.units_skipped;
  if (outcome.units_skipped > 0)
    note(progress, "resuming: " + std::to_string(outcome.units_skipped) + " fits already recorded in " + c.out);
  WarmStarts warm_starts(c.out);
  const auto t0 = Clock::now();
  std::vector<int> pending_runs;
  for (int r = 1; r <= c.runs; ++r) {
    bool all_done = true;
    for (const auto& e : c.estimators)
      all_done = all_done && table.contains({{"run", std::to_string(r)}, {"estimator", e}});
    if (!all_done) pending_runs.push_back(r);
  }
  // Runs fitted side by side share the table, the log, the time estimate and
  // the progress output, and the cores: each fit gets its share of them
  // unless the options ask for a thread count (bench/RESULTS.md compares one
  // thread a fit with every joint at once).
  std::mutex shared;
  EstimatorOptions base = c.base;
  if (c.concurrent_runs > 1 && base.search.threads == 0)
    base.search.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / c.concurrent_runs);
  auto fit_run = [&](int r) {
    nlohmann::json drawn;
    const RobotModel truth = nominal.with_perturbed_kinematics(mix_seed(c.seed, r, 0), 0.05, 5.0 * M_PI / 180.0, &drawn);
    SimulationOptions so;
    so.samples = c.samples;
    so.dt = c.dt;
    so.noise_std = c.noise_std;
    so.seed = mix_seed(c.seed, r, 1);
    const SimulationResult train = simulate(truth, so);
    so.seed = mix_seed(c.seed, r, 2);
    const SimulationResult test = simulate(truth, so);
    for (const auto& e : c.estimators) {
      EstimatorOptions options = options_for(base, e, prior, c.seed + static_cast<std::uint64_t>(r));
      {
        std::lock_guard<std::mutex> lock(shared);
        if (table.contains({{"run", std::to_string(r)}, {"estimator", e}})) continue;
        note(progress, "[run " + std::to_string(r) + "/" + std::to_string(c.runs) + "] " + e + ": fitting " +
                   std::to_string(c.samples) + " samples (elapsed " +
                   duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() + ")");
        const std::vector<Eigen::VectorXd>* start = c.warm_start_runs && r > 1 ? warm_starts.find(e) : nullptr;
        if (start) options.gp.initial_log_params = *start;
      }
      const FitAndPredict f = fit_and_predict(options, train.X, train.tau, joints, test.X);
      const Eigen::VectorXd nmse = f.ok ? compute_accuracy(test.tau_true, f.prediction).nmse
                                        : Eigen::VectorXd::Constant(n, std::nan(""));
      std::vector<std::vector<std::string>> rows;
      for (int j = 0; j < n; ++j)
        rows.push_back({std::to_string(r), e, std::to_string(j + 1), format_number(nmse(j)), format_number(f.seconds)});
      std::lock_guard<std::mutex> lock(shared);
      if (c.warm_start_runs && r == 1) warm_starts.store(e, f.log_params);
      table.append(rows);
      record_fit_report(c.out, {{"run", std::to_string(r)}}, e, f);
      // Side by side, a finished fit's line names its run: the lines of the runs interleave.
      const std::string label = c.concurrent_runs > 1 ? "[run " + std::to_string(r) + "] " + e : e;
      finish_fit(outcome, eta, e, c.out, "run " + std::to_string(r) + " ", e, f, per_joint("nMSE", nmse), progress,
                 label);
    }
  };
  eta.set_concurrency(c.concurrent_runs);
  size_t first = 0;
  // Later runs start from run 1's hyperparameters: it must be done before they begin.
  if (c.warm_start_runs && !pending_runs.empty() && pending_runs.front() == 1) fit_run(pending_runs[first++]);
  const int remaining = static_cast<int>(pending_runs.size() - first);
  if (c.concurrent_runs <= 1) {
    for (size_t i = first; i < pending_runs.size(); ++i) fit_run(pending_runs[i]);
  } else {
    use_single_threaded_blas();  // before the threads: no fit sets it while another computes
    run_tasks(remaining, worker_threads(c.concurrent_runs, remaining),
              [&](int i) { fit_run(pending_runs[first + static_cast<size_t>(i)]); });
  }
  outcome.files.push_back((fs::path(c.out) / "nmse.csv").string());

  outcome.files.push_back(write_summary(c, nominal, table));
  plot_into(outcome, "boxplot", (fs::path(c.out) / "nmse.csv").string(),
            (fs::path(c.out) / "nmse_boxplot.png").string());
  return outcome;
}

}  // namespace gipdyn
