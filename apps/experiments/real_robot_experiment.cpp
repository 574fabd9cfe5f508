#include "experiments/real_robot_experiment.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include "experiments/experiment_runner.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "gipdyn/training_data.hpp"
#include "reports/result_table.hpp"
#include "reports/text_format.hpp"

namespace gipdyn {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

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
  for (int size : sizes)
    if (size < kMinTrainingRows)
      throw Error("--sizes: " + std::to_string(size) + " is below the minimum of " + std::to_string(kMinTrainingRows) +
                  " training rows");
  if (!sizes.empty() && nn_max_train != 0)
    throw Error("--sizes sets the training rows of every estimator, nn included; drop --nn-max-train");
  if (repeats < 1) throw Error("--repeats must be >= 1 (subsamples per training size)");
  if (saturate != -1.0 && !(saturate >= 0.0))
    throw Error("--saturate must be >= 0 (a fraction of each input's training range to allow beyond it)");
  validate_estimators(estimators);
  validate_base_options(base);
  for (const auto& e : estimators)
    if (estimator_needs_robot(parse_estimator_spec(e).student) && robot.empty())
      throw Error("estimator '" + e + "' needs the nominal robot; pass --robot or drop it from --models");
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
          {"seed", base.search.seed},
          {"options", base_options_json(base, estimators)}};
  // Only when set, so folders written before these options existed still resume.
  if (alternate_blocks > 0) j["alternate_blocks"] = alternate_blocks;
  if (nn_max_train > 0) j["nn_max_train"] = nn_max_train;
  if (saturate >= 0.0) j["saturate"] = saturate;
  if (!sizes.empty()) {
    j["sizes"] = sizes;
    j["repeats"] = repeats;
  }
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

RealSplit load_real_split(const RealRobotConfig& c) {
  RealSplit s;
  s.joints = JointTypes::parse(c.joints);
  const Dataset all = read_robot_log(c.data, c.mat_variable, s.joints, true);
  std::vector<Eigen::Index> train_idx;
  if (c.alternate_blocks > 0) {
    const Eigen::Index B = c.alternate_blocks;
    if (all.rows() < 2 * B)
      throw Error("--alternate-blocks " + std::to_string(B) + " needs at least " + std::to_string(2 * B) +
                  " rows but '" + c.data + "' has " + std::to_string(all.rows()) + "; use smaller blocks");
    for (Eigen::Index r = 0; r < all.rows(); ++r) ((r / B) % 2 == 0 ? train_idx : s.test_rows).push_back(r);
    s.description = "alternating blocks of " + std::to_string(B) + " rows (odd blocks train, even blocks test)";
  } else {
    for (const auto& [name, range] : {std::pair{"--train-rows", c.train_rows}, std::pair{"--test-rows", c.test_rows}})
      if (range.second > all.rows())
        throw Error(std::string(name) + " ends at row " + std::to_string(range.second) + " but '" + c.data +
                    "' has " + std::to_string(all.rows()) + " data rows");
    for (long k = c.train_rows.first; k <= c.train_rows.second; ++k) train_idx.push_back(k - 1);
    for (long k = c.test_rows.first; k <= c.test_rows.second; ++k) s.test_rows.push_back(k - 1);
    s.description = "train rows " + std::to_string(c.train_rows.first) + "-" + std::to_string(c.train_rows.second) +
                    ", test rows " + std::to_string(c.test_rows.first) + "-" + std::to_string(c.test_rows.second);
  }
  s.train = all.subset(train_idx);
  s.test = all.subset(s.test_rows);
  if (const Eigen::Index shared = count_shared_rows(s.train.X, s.test.X); shared > 0)
    s.warnings.push_back(std::to_string(shared) + " of the " + std::to_string(s.test.rows()) +
                         " test rows also appear among the training rows: their error is not a test error");
  const std::string constant = joint_numbers(constant_columns(s.test.tau, 0.0));
  if (!constant.empty())
    s.warnings.push_back("joint(s) " + constant + ": the torque is constant over the test rows (a dead sensor, a column "
                         "of zeros?), so their nMSE, and the mean over joints, is undefined (inf): judge the other "
                         "joints one by one");
  for (int size : c.sizes)
    if (size > s.train.rows())
      throw Error("--sizes: " + std::to_string(size) + " is more than the " + std::to_string(s.train.rows()) +
                  " training rows of this split; use sizes up to " + std::to_string(s.train.rows()));
  if (!c.robot.empty()) {
    s.prior.robot = std::make_shared<const RobotModel>(load_robot(c.robot));
    s.prior.friction = c.robot_friction;
  }
  return s;
}

Eigen::MatrixXd test_inputs(const RealRobotConfig& c, const RealSplit& s, const Dataset& trained_on) {
  Eigen::MatrixXd X = s.test.X;
  if (c.saturate >= 0.0) InputBox::of(trained_on.X).saturate(X, s.joints, c.saturate);
  return X;
}

namespace {

// test_window.csv: measured and predicted torque over the first plot_window test rows, the predictions of
// fits recorded by an earlier invocation read back from their CSV; its path.
std::string write_test_window(const RealRobotConfig& c, const RealSplit& s,
                              std::map<std::string, Eigen::MatrixXd>& predictions) {
  const Dataset& test = s.test;
  const std::vector<Eigen::Index>& test_idx = s.test_rows;
  const int n = s.joints.size();
  const Eigen::Index window = std::min<Eigen::Index>(c.plot_window, test.rows());
  std::vector<std::string> header{"row"};
  for (const auto& t : torque_column_names(n)) header.push_back(t);
  Eigen::MatrixXd P(window, 1 + n);
  for (Eigen::Index k = 0; k < window; ++k) P(k, 0) = static_cast<double>(test_idx[static_cast<size_t>(k)] + 1);
  P.rightCols(n) = test.tau.topRows(window);
  for (const auto& e : c.estimators) {
    const std::string file = (fs::path(c.out) / ("predictions_" + e + ".csv")).string();
    if (!predictions.count(e) && fs::exists(file))
      predictions[e] = read_csv_columns(file, torque_column_names(n, "_hat"));
    if (!predictions.count(e)) continue;
    const Eigen::MatrixXd& pred = predictions[e];
    if (pred.rows() != test.rows()) continue;
    Eigen::MatrixXd wider(window, P.cols() + n);
    wider << P, pred.topRows(window);
    P = wider;
    for (const auto& t : torque_column_names(n)) header.push_back(e + "_" + t);
  }
  const std::string window_csv = (fs::path(c.out) / "test_window.csv").string();
  write_csv(window_csv, header, P);
  return window_csv;
}

}  // namespace

ExperimentOutcome run_real_robot_experiment(const RealRobotConfig& c, const ProgressCallback& progress) {
  c.validate();
  if (!c.sizes.empty()) return run_real_learning_curve(c, progress);
  const RealSplit s = load_real_split(c);
  const JointTypes& joints = s.joints;
  const int n = joints.size();
  const Dataset &train = s.train, &test = s.test;
  const std::string& split = s.description;
  const RobotPrior& prior = s.prior;
  const Dataset train_gp = train.subset(constant_step_indices(train.rows(), c.max_train));
  const Dataset train_nn = train.subset(constant_step_indices(train.rows(), c.nn_max_train));
  prepare_folder(c.out, c.to_json());
  ResultTable table((fs::path(c.out) / "nmse.csv").string(),
                    {"estimator", "joint", "nmse", "seconds", "training_rows"});
  ExperimentOutcome outcome;
  outcome.warnings = s.warnings;
  Eta eta;
  for (const auto& e : c.estimators)
    if (table.contains({{"estimator", e}})) ++outcome.units_skipped;
    else eta.add_pending(e, 1);
  note(progress, split + ": " + std::to_string(train.rows()) + " training rows (" + std::to_string(train_gp.rows()) +
                     " for GP estimators, " + std::to_string(train_nn.rows()) + " for nn, constant step), " +
                     std::to_string(test.rows()) + " test rows");
  if (outcome.units_skipped > 0)
    note(progress, "resuming: " + std::to_string(outcome.units_skipped) + " estimators already recorded in " + c.out);
  // Test predictions of this invocation's fits, for the plot window; those of
  // fits recorded by an earlier invocation are read back from their CSV.
  std::map<std::string, Eigen::MatrixXd> predictions;
  const auto t0 = Clock::now();
  for (const auto& e : c.estimators) {
    if (table.contains({{"estimator", e}})) continue;
    // GP estimators scale as N^3 and get the subsample; fe uses every training row, nn its own subsample.
    const std::string student = parse_estimator_spec(e).student;
    const Dataset& d = is_kernel_estimator(student)                                        ? train_gp
                        : estimator_family(student) == EstimatorFamily::NeuralNetwork ? train_nn
                                                                                       : train;
    note(progress, e + ": fitting " + std::to_string(d.rows()) + " rows (elapsed " +
               duration(std::chrono::duration<double>(Clock::now() - t0).count()) + ", " + eta.left() + ")");
    const Eigen::MatrixXd Xtest = test_inputs(c, s, d);
    if (c.saturate >= 0.0)
      note(progress, "  " + std::to_string(InputBox::of(d.X).rows_outside(test.X, joints, c.saturate)) + " of " +
                         std::to_string(test.rows()) + " test rows saturated into the training box");
    const FitAndPredict f = fit_and_predict(options_for(c.base, e, prior, c.base.search.seed), d.X, d.tau, joints, Xtest);
    Eigen::VectorXd nmse = Eigen::VectorXd::Constant(n, std::nan(""));
    if (f.ok) {
      nmse = compute_accuracy(test.tau, f.prediction).nmse;
      write_csv((fs::path(c.out) / ("predictions_" + e + ".csv")).string(), torque_column_names(n, "_hat"),
                f.prediction);
      predictions[e] = f.prediction;
    }
    std::vector<std::vector<std::string>> rows;
    for (int j = 0; j < n; ++j)
      rows.push_back({e, std::to_string(j + 1), format_number(nmse(j)), format_number(f.seconds),
                      std::to_string(d.rows())});
    table.append(rows);
    record_fit_report(c.out, {}, e, f);
    finish_fit(outcome, eta, e, c.out, "", e, f, per_joint("nMSE", nmse), progress);
  }
  outcome.files.push_back((fs::path(c.out) / "nmse.csv").string());

  const std::string window_csv = write_test_window(c, s, predictions);
  outcome.files.push_back(window_csv);

  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# Real robot: " << c.data << (c.mat_variable.empty() ? "" : " (variable " + c.mat_variable + ")") << ", joints "
      << joints.str() << "\n\n";
    o << "Split: " << split << ". " << train.rows() << " training rows (GP estimators: " << train_gp.rows()
      << " of them, constant step; nn: " << train_nn.rows() << "; fe: all), " << test.rows()
      << " test rows. Test nMSE against the measured torque"
      << (prior.robot ? "; nominal robot " + prior.robot->name() + (prior.friction ? " with friction" : "") : "")
      << ".";
    if (c.saturate >= 0.0)
      o << " Test inputs saturated into each estimator's training box widened by " << c.saturate
        << " of its range (revolute positions excepted): "
        << InputBox::of(train_gp.X).rows_outside(test.X, joints, c.saturate) << " of " << test.rows()
        << " rows moved for the GP estimators.";
    std::vector<std::string> columns{"estimator"};
    for (const std::string& c : joint_columns(n)) columns.push_back(c);
    columns.insert(columns.end(), {"mean", "fit time"});
    o << "\n\n" << markdown_table_header(columns);
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
