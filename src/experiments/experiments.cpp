#include "gipdyn/experiments/experiments.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "gipdyn/error.hpp"
#include "gipdyn/experiments/plots.hpp"
#include "gipdyn/experiments/result_table.hpp"
#include "gipdyn/io/atomic_file.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace gipdyn {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  // splitmix64 of a combination: well-separated streams for (seed, run, purpose).
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + a * 0xBF58476D1CE4E5B9ULL + b * 0x94D049BB133111EBULL + 1;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::string duration(double s) {
  char buf[32];
  if (s < 60) std::snprintf(buf, sizeof buf, "%.0fs", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600, (static_cast<int>(s) % 3600) / 60);
  return buf;
}

// The folder and its config.json: a restart must use the same settings.
void prepare_folder(const std::string& out, const nlohmann::json& config) {
  if (out.empty()) throw Error("--out is required: the folder for the experiment's files");
  fs::create_directories(out);
  const std::string path = (fs::path(out) / "config.json").string();
  if (fs::exists(path)) {
    nlohmann::json old;
    try {
      std::ifstream in(path);
      old = nlohmann::json::parse(in);
    } catch (const std::exception&) {
      throw Error("'" + path + "' is unreadable; delete it (and the results beside it) or use another --out");
    }
    if (old != config)
      throw Error("'" + out + "' holds an experiment with other settings (config.json differs: was " + old.dump() +
                  "); use another --out, or the same settings to resume");
    return;
  }
  write_file_atomically(path, [&](std::ostream& o) { o << config.dump(2) << "\n"; });
}

// Estimates time left from the seconds each estimator took so far (including
// runs recorded by earlier invocations).
class Eta {
 public:
  void record(const std::string& estimator, double seconds) {
    auto& [sum, count] = stats_[estimator];
    sum += seconds;
    ++count;
  }
  void add_pending(const std::string& estimator, int units) { pending_[estimator] += units; }
  void finish(const std::string& estimator) { --pending_[estimator]; }
  std::string left() const {
    double total = 0.0, known_sum = 0.0;
    int known = 0;
    for (const auto& [e, sc] : stats_) {
      known_sum += sc.first;
      known += sc.second;
    }
    for (const auto& [e, n] : pending_) {
      if (n <= 0) continue;
      auto it = stats_.find(e);
      if (it != stats_.end() && it->second.second > 0) total += n * it->second.first / it->second.second;
      else if (known > 0) total += n * known_sum / known;
      else return "time left unknown yet";
    }
    return "about " + duration(total) + " left";
  }

 private:
  std::map<std::string, std::pair<double, int>> stats_;
  std::map<std::string, int> pending_;
};

struct FitAndPredict {
  bool ok = false;
  std::string message;
  double seconds = 0.0;
  Eigen::MatrixXd prediction;
};

FitAndPredict fit_and_predict(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                              const JointTypes& joints, const Eigen::MatrixXd& Xtest) {
  FitAndPredict out;
  const auto t0 = Clock::now();
  try {
    FitResult r = fit_estimator(options, X, Y, joints);
    out.ok = r.ok;
    out.message = r.message;
    if (r.ok) out.prediction = r.estimator->predict(Xtest);
    if (out.ok && !out.prediction.allFinite()) {
      out.ok = false;
      out.message = "predictions contain NaN or Inf";
    }
  } catch (const Error& e) {
    out.message = e.what();
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

EstimatorOptions options_for(const EstimatorOptions& base, const std::string& name, const RobotPrior& prior,
                             std::uint64_t seed) {
  EstimatorOptions o = base;
  o.name = name;
  if (estimator_needs_robot(name)) o.robot_prior = prior;
  o.gp.seed = seed;
  o.nn.seed = seed;
  return o;
}

void log_line(const std::string& out, const std::string& line) {
  std::ofstream log((fs::path(out) / "experiment.log").string(), std::ios::app);
  log << line << "\n";
}

std::string sci(double v) {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2e", v);
  return buf;
}

std::string per_joint(const std::string& label, const Eigen::VectorXd& v) {
  std::string line = label;
  for (Eigen::Index j = 0; j < v.size(); ++j) line += " " + sci(v(j));
  return line;
}

// The bookkeeping of one finished fit, whatever the experiment: counts, the
// failure log, the time estimate and the progress line. `where` prefixes the
// log line ("run 3 "), `metrics` ends the progress line ("nMSE 1e-3 ...").
void finish_fit(ExperimentOutcome& outcome, Eta& eta, const std::string& eta_key, const std::string& out,
                const std::string& where, const std::string& estimator, const FitAndPredict& f,
                const std::string& metrics, const ExperimentCallback& progress) {
  if (f.ok) {
    ++outcome.units_done;
  } else {
    ++outcome.units_failed;
    log_line(out, where + estimator + " failed: " + f.message);
    if (progress) progress("  " + estimator + " failed: " + f.message);
  }
  eta.record(eta_key, f.seconds);
  eta.finish(eta_key);
  if (progress) progress("  " + estimator + " done in " + duration(f.seconds) + ", " + metrics);
}

double quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}


void plot_into(ExperimentOutcome& outcome, const std::string& kind, const std::string& input, const std::string& png) {
  const PlotResult p = render_plot(kind, input, png);
  if (p.ok) outcome.files.push_back(png);
  else outcome.warnings.push_back(p.message);
}

nlohmann::json base_options_json(const EstimatorOptions& b) {
  nlohmann::json j = {{"optimizer", b.gp.optimizer.kind == OptimizerKind::Adam ? "adam" : "lbfgs"},
          {"max_iter", b.gp.optimizer.max_iterations},
          {"restarts", b.gp.restarts},
          {"scaling", to_string(b.gp.scaling)},
          {"min_noise", b.gp.min_noise_fraction},
          {"prior", b.gp.prior.enabled ? "lognormal" : "none"},
          {"prior_width", b.gp.prior.width},
          {"nn_hidden", b.nn.hidden},
          {"nn_epochs", b.nn.epochs},
          {"nn_batch", b.nn.batch_size},
          {"nn_lr", b.nn.learning_rate}};
  // Only when set, so folders written before mean functions existed still resume.
  if (b.gp.mean != MeanKind::Zero) j["mean"] = to_string(b.gp.mean);
  return j;
}

void validate_estimators(const std::vector<std::string>& estimators) {
  if (estimators.empty()) throw Error("--estimators: name at least one estimator");
  for (const auto& e : estimators) require_known_estimator(e);
}

}  // namespace

std::pair<long, long> parse_row_range(const std::string& text, const std::string& option) {
  const auto dash = text.find('-');
  try {
    if (dash != std::string::npos) {
      size_t used1 = 0, used2 = 0;
      const long a = std::stol(text.substr(0, dash), &used1), b = std::stol(text.substr(dash + 1), &used2);
      if (used1 == dash && used2 == text.size() - dash - 1 && a >= 1 && b >= a) return {a, b};
    }
  } catch (const std::exception&) {
  }
  throw Error(option + " '" + text + "' is not a row range; write FIRST-LAST with 1-based data rows, e.g. 1-6340");
}

// ---------------------------------------------------------------- E1 accuracy

void AccuracyConfig::validate() const {
  if (runs < 1) throw Error("--runs must be >= 1");
  if (samples < kMinTrainingRows) throw Error("--samples must be >= " + std::to_string(kMinTrainingRows));
  if (!(dt > 0.0)) throw Error("--dt must be > 0");
  if (!(noise_std >= 0.0)) throw Error("--noise must be >= 0");
  validate_estimators(estimators);
}

nlohmann::json AccuracyConfig::to_json() const {
  // Not `runs`: an experiment may be extended with more runs.
  return {{"experiment", "accuracy"}, {"robot", robot},   {"samples", samples},
          {"seed", seed},             {"dt", dt},         {"noise", noise_std},  {"estimators", estimators},
          {"options", base_options_json(base)}};
}

ExperimentOutcome run_accuracy_experiment(const AccuracyConfig& c, const ExperimentCallback& progress) {
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
  if (progress && outcome.units_skipped > 0)
    progress("resuming: " + std::to_string(outcome.units_skipped) + " fits already recorded in " + c.out);
  const auto t0 = Clock::now();
  for (int r = 1; r <= c.runs; ++r) {
    bool all_done = true;
    for (const auto& e : c.estimators)
      all_done = all_done && table.contains({{"run", std::to_string(r)}, {"estimator", e}});
    if (all_done) continue;
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
      if (table.contains({{"run", std::to_string(r)}, {"estimator", e}})) continue;
      if (progress)
        progress("[run " + std::to_string(r) + "/" + std::to_string(c.runs) + "] " + e + ": fitting " +
                 std::to_string(c.samples) + " samples (elapsed " +
                 duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() + ")");
      const FitAndPredict f =
          fit_and_predict(options_for(c.base, e, prior, c.seed + static_cast<std::uint64_t>(r)), train.X, train.tau,
                          joints, test.X);
      const Eigen::VectorXd nmse = f.ok ? compute_accuracy(test.tau_true, f.prediction).nmse
                                        : Eigen::VectorXd::Constant(n, std::nan(""));
      std::vector<std::vector<std::string>> rows;
      for (int j = 0; j < n; ++j)
        rows.push_back({std::to_string(r), e, std::to_string(j + 1), format_number(nmse(j)), format_number(f.seconds)});
      table.append(rows);
      finish_fit(outcome, eta, e, c.out, "run " + std::to_string(r) + " ", e, f, per_joint("nMSE", nmse), progress);
    }
  }
  outcome.files.push_back((fs::path(c.out) / "nmse.csv").string());

  // summary.md: median and quartiles per estimator and joint.
  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# E1, accuracy under model bias: " << nominal.name() << " (" << joints.str() << ")\n\n";
    o << c.runs << " runs, " << c.samples << " training and " << c.samples << " test samples per run, dt " << c.dt
      << " s, noise std " << c.noise_std << ", seed " << c.seed
      << ". nMSE on the noise-free test torque; median [first quartile, third quartile] over runs.\n\n";
    o << "| estimator |";
    for (int j = 1; j <= n; ++j) o << " joint " << j << " |";
    o << " runs < 1 % on every joint | mean fit time |\n|---|";
    for (int j = 0; j <= n + 1; ++j) o << "---|";
    o << "\n";
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
  outcome.files.push_back(summary);
  plot_into(outcome, "boxplot", (fs::path(c.out) / "nmse.csv").string(),
            (fs::path(c.out) / "nmse_boxplot.png").string());
  return outcome;
}

// ------------------------------------------------------- E2 data efficiency

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
}

nlohmann::json DataEfficiencyConfig::to_json() const {
  return {{"experiment", "data-efficiency"}, {"robot", robot}, {"train_samples", train_samples},
          {"test_samples", test_samples},    {"sizes", sizes},
          {"seed", seed},                    {"dt", dt},       {"noise", noise_std},
          {"estimators", estimators},        {"options", base_options_json(base)}};
}

ExperimentOutcome run_data_efficiency_experiment(const DataEfficiencyConfig& c, const ExperimentCallback& progress) {
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
  if (progress && outcome.units_skipped > 0)
    progress("resuming: " + std::to_string(outcome.units_skipped) + " fits already recorded in " + c.out);
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
        if (progress)
          progress("[run " + std::to_string(r) + "/" + std::to_string(c.runs) + ", " + std::to_string(s) +
                   " samples] " + e + ": fitting (elapsed " +
                   duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() + ")");
        const FitAndPredict f =
            fit_and_predict(options_for(c.base, e, prior, c.seed + static_cast<std::uint64_t>(r)), X, Y, joints, test.X);
        const double gmse = f.ok ? compute_accuracy(test.tau_true, f.prediction).gmse : std::nan("");
        table.append({{std::to_string(r), std::to_string(s), e, format_number(gmse), format_number(f.seconds)}});
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
      << c.runs << " run(s). dt " << c.dt << " s, noise std " << c.noise_std << ", seed " << c.seed << ".\n\n| samples |";
    for (const auto& e : c.estimators) o << " " << e << " |";
    o << "\n|---|";
    for (size_t k = 0; k < c.estimators.size(); ++k) o << "---|";
    o << "\n";
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

// ------------------------------------------------------------ E3 real robot

void RealRobotConfig::validate() const {
  if (data.empty()) throw Error("--data is required: the robot log (CSV, or .mat with --mat-variable)");
  if (joints.empty()) throw Error("--joints is required, e.g. RRRRRR");
  JointTypes::parse(joints);
  if (alternate_blocks < 0) throw Error("--alternate-blocks must be >= 1 rows");
  if (alternate_blocks > 0 && (train_rows.first > 0 || test_rows.first > 0))
    throw Error("--alternate-blocks splits the whole log; drop --train-rows/--test-rows/--protocol or drop it");
  if (alternate_blocks == 0 && (train_rows.first < 1 || test_rows.first < 1))
    throw Error("--train-rows and --test-rows are required (or --protocol ur10, or --alternate-blocks ROWS), e.g. "
                "--train-rows 1-6340");
  if (max_train < kMinTrainingRows) throw Error("--max-train must be >= " + std::to_string(kMinTrainingRows));
  if (nn_max_train != 0 && nn_max_train < kMinTrainingRows)
    throw Error("--nn-max-train must be 0 (every row) or >= " + std::to_string(kMinTrainingRows));
  if (plot_window < 1) throw Error("--plot-window must be >= 1");
  validate_estimators(estimators);
  for (const auto& e : estimators)
    if (estimator_needs_robot(e) && robot.empty())
      throw Error("estimator '" + e + "' needs the nominal robot; pass --robot or drop it from --estimators");
}

nlohmann::json RealRobotConfig::to_json() const {
  nlohmann::json j = {{"experiment", "real"},
          {"data", fs::absolute(data).lexically_normal().string()},
          {"mat_variable", mat_variable},
          {"joints", joints},
          {"train_rows", {train_rows.first, train_rows.second}},
          {"test_rows", {test_rows.first, test_rows.second}},
          {"max_train", max_train},
          {"estimators", estimators},
          {"robot", robot},
          {"robot_friction", robot_friction},
          {"seed", base.gp.seed},
          {"options", base_options_json(base)}};
  // Only when set, so folders written before these options existed still resume.
  if (alternate_blocks > 0) j["alternate_blocks"] = alternate_blocks;
  if (nn_max_train > 0) j["nn_max_train"] = nn_max_train;
  return j;
}

void apply_protocol(const std::string& protocol, RealRobotConfig& c) {
  if (protocol.empty()) return;
  if (protocol != "ur10")
    throw Error("unknown --protocol '" + protocol + "'; the built-in one is ur10 (or give --train-rows/--test-rows)");
  // ../shared/data/README.md: train on data rows 1-6340, test on 6341-12349.
  if (c.train_rows.first < 1) c.train_rows = {1, 6340};
  if (c.test_rows.first < 1) c.test_rows = {6341, 12349};
  if (c.joints.empty()) c.joints = "RRRRRR";
  if (c.robot.empty()) {
    c.robot = "ur10";
    c.robot_friction = true;  // the torques come from motor currents: friction is in the signal
  }
}

ExperimentOutcome run_real_robot_experiment(const RealRobotConfig& c, const ExperimentCallback& progress) {
  c.validate();
  const JointTypes joints = JointTypes::parse(c.joints);
  const int n = joints.size();
  const Dataset all = c.mat_variable.empty() ? read_dataset(c.data, joints, true)
                                             : read_mat_dataset(c.data, c.mat_variable, joints, true);
  // 0-based row indices of the two sets, and how to describe them.
  std::vector<Eigen::Index> train_idx, test_idx;
  std::string split;
  if (c.alternate_blocks > 0) {
    const Eigen::Index B = c.alternate_blocks;
    if (all.rows() < 2 * B)
      throw Error("--alternate-blocks " + std::to_string(B) + " needs at least " + std::to_string(2 * B) +
                  " rows but '" + c.data + "' has " + std::to_string(all.rows()) + "; use smaller blocks");
    for (Eigen::Index r = 0; r < all.rows(); ++r) ((r / B) % 2 == 0 ? train_idx : test_idx).push_back(r);
    split = "alternating blocks of " + std::to_string(B) + " rows (odd blocks train, even blocks test)";
  } else {
    for (const auto& [name, range] : {std::pair{"--train-rows", c.train_rows}, std::pair{"--test-rows", c.test_rows}})
      if (range.second > all.rows())
        throw Error(std::string(name) + " ends at row " + std::to_string(range.second) + " but '" + c.data +
                    "' has " + std::to_string(all.rows()) + " data rows");
    for (long k = c.train_rows.first; k <= c.train_rows.second; ++k) train_idx.push_back(k - 1);
    for (long k = c.test_rows.first; k <= c.test_rows.second; ++k) test_idx.push_back(k - 1);
    split = "train rows " + std::to_string(c.train_rows.first) + "-" + std::to_string(c.train_rows.second) +
            ", test rows " + std::to_string(c.test_rows.first) + "-" + std::to_string(c.test_rows.second);
  }
  const Dataset train = all.subset(train_idx), test = all.subset(test_idx);
  const Dataset train_gp = train.subset(constant_step_indices(train.rows(), c.max_train));
  const Dataset train_nn = train.subset(constant_step_indices(train.rows(), c.nn_max_train));
  RobotPrior prior;
  if (!c.robot.empty()) {
    prior.robot = std::make_shared<const RobotModel>(load_robot(c.robot));
    prior.friction = c.robot_friction;
  }
  prepare_folder(c.out, c.to_json());
  ResultTable table((fs::path(c.out) / "nmse.csv").string(),
                    {"estimator", "joint", "nmse", "seconds", "training_rows"});
  ExperimentOutcome outcome;
  Eta eta;
  for (const auto& e : c.estimators)
    if (table.contains({{"estimator", e}})) ++outcome.units_skipped;
    else eta.add_pending(e, 1);
  if (progress) {
    progress(split + ": " + std::to_string(train.rows()) + " training rows (" + std::to_string(train_gp.rows()) +
             " for GP estimators, " + std::to_string(train_nn.rows()) + " for nn, constant step), " +
             std::to_string(test.rows()) + " test rows");
    if (outcome.units_skipped > 0)
      progress("resuming: " + std::to_string(outcome.units_skipped) + " estimators already recorded in " + c.out);
  }
  const auto t0 = Clock::now();
  for (const auto& e : c.estimators) {
    if (table.contains({{"estimator", e}})) continue;
    // GP estimators scale as N^3 and get the subsample; fe uses every training row, nn its own subsample.
    const Dataset& d = is_gp_estimator(e) ? train_gp : e == "nn" ? train_nn : train;
    if (progress)
      progress(e + ": fitting " + std::to_string(d.rows()) + " rows (elapsed " +
               duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() + ")");
    const FitAndPredict f = fit_and_predict(options_for(c.base, e, prior, c.base.gp.seed), d.X, d.tau, joints, test.X);
    Eigen::VectorXd nmse = Eigen::VectorXd::Constant(n, std::nan(""));
    if (f.ok) {
      nmse = compute_accuracy(test.tau, f.prediction).nmse;
      write_csv((fs::path(c.out) / ("predictions_" + e + ".csv")).string(), torque_column_names(n, "_hat"),
                f.prediction);
    }
    std::vector<std::vector<std::string>> rows;
    for (int j = 0; j < n; ++j)
      rows.push_back({e, std::to_string(j + 1), format_number(nmse(j)), format_number(f.seconds),
                      std::to_string(d.rows())});
    table.append(rows);
    finish_fit(outcome, eta, e, c.out, "", e, f, per_joint("nMSE", nmse), progress);
  }
  outcome.files.push_back((fs::path(c.out) / "nmse.csv").string());

  // Measured and predicted torque over the first plot_window test rows.
  const Eigen::Index window = std::min<Eigen::Index>(c.plot_window, test.rows());
  std::vector<std::string> header{"row"};
  for (const auto& t : torque_column_names(n)) header.push_back(t);
  Eigen::MatrixXd P(window, 1 + n);
  for (Eigen::Index k = 0; k < window; ++k) P(k, 0) = static_cast<double>(test_idx[static_cast<size_t>(k)] + 1);
  P.rightCols(n) = test.tau.topRows(window);
  for (const auto& e : c.estimators) {
    const std::string file = (fs::path(c.out) / ("predictions_" + e + ".csv")).string();
    if (!fs::exists(file)) continue;
    const Eigen::MatrixXd pred = read_csv_columns(file, torque_column_names(n, "_hat"));
    if (pred.rows() != test.rows()) continue;
    Eigen::MatrixXd wider(window, P.cols() + n);
    wider << P, pred.topRows(window);
    P = wider;
    for (const auto& t : torque_column_names(n)) header.push_back(e + "_" + t);
  }
  const std::string window_csv = (fs::path(c.out) / "test_window.csv").string();
  write_csv(window_csv, header, P);
  outcome.files.push_back(window_csv);

  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# Real robot: " << c.data << (c.mat_variable.empty() ? "" : " (variable " + c.mat_variable + ")") << ", joints "
      << joints.str() << "\n\n";
    o << "Split: " << split << ". " << train.rows() << " training rows (GP estimators: " << train_gp.rows()
      << " of them, constant step; nn: " << train_nn.rows() << "; fe: all), " << test.rows()
      << " test rows. Test nMSE against the measured torque"
      << (prior.robot ? "; nominal robot " + prior.robot->name() + (prior.friction ? " with friction" : "") : "")
      << ".\n\n| estimator |";
    for (int j = 1; j <= n; ++j) o << " joint " << j << " |";
    o << " mean | fit time |\n|---|";
    for (int j = 0; j <= n + 1; ++j) o << "---|";
    o << "\n";
    for (const auto& e : c.estimators) {
      double sum = 0.0, seconds = std::nan("");
      o << "| " << e << " |";
      for (int j = 1; j <= n; ++j) {
        double v = std::nan("");
        for (const auto& row : table.rows())
          if (row[0] == e && row[1] == std::to_string(j)) {
            v = std::stod(row[2]);
            seconds = std::stod(row[3]);
          }
        sum += v;
        o << " " << sci(v) << " |";
      }
      o << " " << sci(sum / n) << " | " << (std::isnan(seconds) ? "n/a" : duration(seconds)) << " |\n";
    }
  });
  outcome.files.push_back(summary);
  plot_into(outcome, "bars", (fs::path(c.out) / "nmse.csv").string(), (fs::path(c.out) / "nmse_bar.png").string());
  plot_into(outcome, "timeseries", window_csv, (fs::path(c.out) / "torque_time.png").string());
  return outcome;
}

}  // namespace gipdyn
