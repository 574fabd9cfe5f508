// Learning curves on a real robot log: every estimator on interleaved
// constant-step subsamples of several sizes of the same training rows, tested
// on the same test rows. Structure should pay most at small sizes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "experiments/experiment_runner.hpp"
#include "experiments/real_robot_experiment.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/metrics.hpp"
#include "reports/result_table.hpp"
#include "reports/text_format.hpp"

namespace gipdyn {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

// nMSE values of one (estimator, size, joint) over the repeats; joint 0: the mean over joints.
std::vector<double> recorded_nmse(const ResultTable& table, const std::string& estimator, int size, int joint,
                                  int num_joints) {
  std::map<std::string, std::pair<double, int>> by_repeat;  // repeat -> (sum, count)
  for (const auto& row : table.rows()) {
    if (row[0] != estimator || row[1] != std::to_string(size)) continue;
    if (joint > 0 && row[3] != std::to_string(joint)) continue;
    auto& [sum, count] = by_repeat[row[2]];
    sum += std::stod(row[4]);
    ++count;
  }
  std::vector<double> v;
  for (const auto& [repeat, sc] : by_repeat)
    if (joint > 0 || sc.second == num_joints) v.push_back(sc.first / sc.second);
  return v;
}

std::string median_and_range(std::vector<double> v) {
  if (v.empty()) return "n/a";
  std::sort(v.begin(), v.end());
  std::string s = sci(quantile(v, 0.5));
  if (v.size() > 1) s += " (" + sci(v.front()) + "–" + sci(v.back()) + ")";
  return s;
}

}  // namespace

ExperimentOutcome run_real_learning_curve(const RealRobotConfig& c, const ProgressCallback& progress) {
  c.validate();
  const RealSplit s = load_real_split(c);
  const int n = s.joints.size();
  prepare_folder(c.out, c.to_json());
  const std::string csv = (fs::path(c.out) / "learning_curve.csv").string();
  ResultTable table(csv, {"estimator", "size", "repeat", "joint", "nmse", "seconds"});
  ExperimentOutcome outcome;
  outcome.warnings = s.warnings;
  auto key = [](const std::string& e, int size, int r) {
    return std::vector<std::pair<std::string, std::string>>{
        {"estimator", e}, {"size", std::to_string(size)}, {"repeat", std::to_string(r)}};
  };
  Eta eta;
  for (const auto& row : table.rows())
    if (row[3] == "1") eta.record(row[0] + "@" + row[1], std::stod(row[5]));
  for (int size : c.sizes)
    for (int r = 1; r <= c.repeats; ++r)
      for (const auto& e : c.estimators)
        if (table.contains(key(e, size, r))) ++outcome.units_skipped;
        else eta.add_pending(e + "@" + std::to_string(size), 1);
  note(progress, s.description + ": " + std::to_string(s.train.rows()) + " training rows, " +
                     std::to_string(s.test.rows()) + " test rows; " + std::to_string(c.repeats) +
                     " interleaved constant-step subsamples of each size");
  if (outcome.units_skipped > 0)
    note(progress, "resuming: " + std::to_string(outcome.units_skipped) + " fits already recorded in " + c.out);
  const auto t0 = Clock::now();
  for (int size : c.sizes)
    for (int r = 1; r <= c.repeats; ++r) {
      const Dataset d = s.train.subset(constant_step_indices(s.train.rows(), size, r - 1, c.repeats));
      for (const auto& e : c.estimators) {
        if (table.contains(key(e, size, r))) continue;
        note(progress, "[" + std::to_string(size) + " rows, repeat " + std::to_string(r) + "/" +
                           std::to_string(c.repeats) + "] " + e + ": fitting (elapsed " +
                           duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() +
                           ")");
        const std::uint64_t seed = mix_seed(c.base.search.seed, static_cast<std::uint64_t>(size), r);
        const Eigen::MatrixXd Xtest = test_inputs(c, s, d);
        const FitAndPredict f = fit_and_predict(options_for(c.base, e, s.prior, seed), d.X, d.tau, s.joints, Xtest);
        Eigen::VectorXd nmse = Eigen::VectorXd::Constant(n, std::nan(""));
        if (f.ok) nmse = compute_accuracy(s.test.tau, f.prediction).nmse;
        std::vector<std::vector<std::string>> rows;
        for (int j = 0; j < n; ++j)
          rows.push_back({e, std::to_string(size), std::to_string(r), std::to_string(j + 1), format_number(nmse(j)),
                          format_number(f.seconds)});
        table.append(rows);
        record_fit_report(c.out, {{"size", std::to_string(size)}, {"repeat", std::to_string(r)}}, e, f);
        finish_fit(outcome, eta, e + "@" + std::to_string(size), c.out,
                   "size " + std::to_string(size) + " repeat " + std::to_string(r) + " ", e, f,
                   per_joint("nMSE", nmse), progress);
      }
    }
  outcome.files.push_back(csv);

  const std::string summary = (fs::path(c.out) / "learning_curve.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# Learning curve: " << c.data << (c.mat_variable.empty() ? "" : " (variable " + c.mat_variable + ")")
      << ", joints " << s.joints.str() << "\n\n";
    o << "Split: " << s.description << ". Each size is trained on " << c.repeats
      << " interleaved constant-step subsamples of the " << s.train.rows()
      << " training rows and tested on the " << s.test.rows()
      << " test rows against the measured torque. Entries: median over the subsamples (min–max).";
    if (c.saturate >= 0.0)
      o << " Test inputs saturated into each subsample's training box widened by " << c.saturate
        << " of its range (revolute positions excepted).";
    o << "\n\n";
    auto table_header = [&](const std::string& first) {
      std::vector<std::string> columns{first};
      columns.insert(columns.end(), c.estimators.begin(), c.estimators.end());
      o << markdown_table_header(columns);
    };
    o << "## Mean test nMSE over joints\n\n";
    table_header("rows");
    for (int size : c.sizes) {
      o << "| " << size << " |";
      for (const auto& e : c.estimators) o << " " << median_and_range(recorded_nmse(table, e, size, 0, n)) << " |";
      o << "\n";
    }
    for (int j = 1; j <= n; ++j) {
      o << "\n## Joint " << j << "\n\n";
      table_header("rows");
      for (int size : c.sizes) {
        o << "| " << size << " |";
        for (const auto& e : c.estimators) o << " " << median_and_range(recorded_nmse(table, e, size, j, n)) << " |";
        o << "\n";
      }
    }
  });
  outcome.files.push_back(summary);
  plot_into(outcome, "learning_curve", csv, (fs::path(c.out) / "learning_curve.png").string());
  return outcome;
}

}  // namespace gipdyn
