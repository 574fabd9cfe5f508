// `gipdyn inspect`: before training, is the torque of a log a function of its
// logged state, and does a test log follow the same function? (data_consistency.hpp)
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "exit_codes.hpp"
#include "cli_parsing.hpp"
#include "commands.hpp"
#include "data_option.hpp"
#include "field_names.hpp"
#include "output_guard.hpp"
#include "gipdyn/data_consistency.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/detail/json_numbers.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/training_data.hpp"
#include "reports/plots.hpp"

namespace gipdyn::cli {
namespace {

struct InspectArgs {
  std::string data, mat_variable, columns, joints, train_rows, test_rows, test, out, plot;
  NeighbourConsistencyOptions options;
  bool quiet = false;
};

Dataset rows_of(const Dataset& all, const std::string& range, const char* flag) {
  if (range.empty()) return all;
  const auto [first, last] = parse_row_range(range, flag);
  if (last > all.rows())
    throw Error(std::string(flag) + " " + range + ": the log has only " + std::to_string(all.rows()) +
                " data rows; give a range inside 1-" + std::to_string(all.rows()));
  std::vector<Eigen::Index> rows;
  for (long k = first; k <= last; ++k) rows.push_back(k - 1);
  return all.subset(rows);
}

nlohmann::json to_json(const NeighbourConsistency& c) {
  return {{"status", to_string(c.status)}, {"message", rename_fields(c.message, cli_field_names())}, {"queries", c.queries},
          {"pairs", c.pairs},              {"neighbour_nmse", numbers_or_null(c.neighbour_nmse)},
          {"correlation", numbers_or_null(c.correlation)}};
}

// One comparison: its table heading, its key in the JSON report, its result.
struct Column {
  std::string label, key;
  NeighbourConsistency result;
};

void print_table(const std::vector<Column>& columns, int joints) {
  std::printf("%6s", "joint");
  for (const auto& [label, key, c] : columns) std::printf("  %-24s", label.c_str());
  std::printf("\n%6s", "");
  for (size_t k = 0; k < columns.size(); ++k) std::printf("  %-11s %-12s", "nMSE", "correlation");
  std::printf("\n");
  for (int j = 0; j < joints; ++j) {
    std::printf("%6d", j + 1);
    for (const auto& [label, key, c] : columns) {
      if (c.status == NeighbourConsistency::Status::Ok)
        std::printf("  %-11.3g %-12.3f", c.neighbour_nmse(j), c.correlation(j));
      else
        std::printf("  %-24s", "-");
    }
    std::printf("\n");
  }
  std::printf("%6s", "pairs");
  for (const auto& [label, key, c] : columns) {
    const std::string text = std::to_string(c.pairs) + " of " + std::to_string(c.queries) + " rows";
    std::printf("  %-24s", text.c_str());
  }
  std::printf("\n");
}

int run_inspect(const InspectArgs& a) {
  if (!a.test.empty() && !a.test_rows.empty())
    throw Error("give the test rows either as --test-rows (of --data) or as a --test file, not both");
  if (!a.test_rows.empty() && a.train_rows.empty())
    throw Error("--test-rows needs --train-rows: the rows of --data to compare the test rows with");
  if (!a.plot.empty() && a.out.empty()) throw Error("--plot draws the report of --out; give --out REPORT.json too");
  std::vector<std::pair<std::string, std::string>> inputs{{"--data", a.data}};
  if (!a.test.empty()) inputs.push_back({"--test", a.test});
  std::vector<std::pair<std::string, std::string>> outputs;
  if (!a.out.empty()) outputs.push_back({"--out", a.out});
  if (!a.plot.empty()) outputs.push_back({"--plot", a.plot});
  refuse_overwrites(inputs, outputs);
  a.options.validate();

  const LogColumns log_columns = parse_log_columns(a.columns);
  const JointTypes joints = joint_types_option(a.joints, a.data, a.mat_variable, "", log_columns);
  NeighbourConsistencyOptions options = a.options;
  options.joints = joints.str();  // revolute positions compared on the circle
  const Dataset log = read_robot_log(a.data, a.mat_variable, joints, true, "", log_columns);
  const Dataset train = rows_of(log, a.train_rows, "--train-rows");
  std::optional<Dataset> test;
  if (!a.test_rows.empty()) test = rows_of(log, a.test_rows, "--test-rows");
  if (!a.test.empty()) test = read_robot_log(a.test, a.mat_variable, joints, true, "", log_columns);

  if (test) {
    if (const Eigen::Index shared = count_shared_rows(train.X, test->X); shared > 0)
      std::fprintf(stderr,
                   "gipdyn: warning: %ld test rows are also training rows, value for value (overlapping row "
                   "ranges, or the robot at rest in one pose in both); where ranges overlap, a row is its own "
                   "neighbour and the training -> test column looks better than it is\n",
                   static_cast<long>(shared));
  }
  std::vector<Column> columns;
  columns.push_back({"within training", "within_training", neighbour_consistency(train.X, train.tau, options)});
  if (test) {
    columns.push_back({"within test", "within_test", neighbour_consistency(test->X, test->tau, options)});
    columns.push_back({"training -> test", "training_to_test",
                       neighbour_consistency(train.X, train.tau, test->X, test->tau, options)});
  }
  nlohmann::json report{{"data", a.data},
                        {"joints", joints.str()},
                        {"training_rows", train.rows()},
                        {"radius", a.options.radius},
                        {"min_separation_rows", a.options.min_separation_rows},
                        {"inputs", a.options.use_accelerations ? "q, qd, qdd" : "q, qd"}};
  for (const auto& [label, key, c] : columns) report[key] = to_json(c);
  Eigen::Index outside = 0;
  if (test) {
    outside = InputBox::of(train.X).rows_outside(test->X, joints, 0.0);
    report["test_rows"] = test->rows();
    report["test_rows_outside_training_box"] = outside;
  }

  if (!a.quiet) {
    std::printf("Rows that visit the same state (%s within %.3g standard deviations, revolute positions on the "
                "circle, at least %ld rows apart within one log) should have the same torque.\nneighbour nMSE: mean squared torque difference over the "
                "variance; 1 = no better than predicting the mean; within one log, half of it is about the noise "
                "share.\n",
                a.options.use_accelerations ? "q, qd, qdd" : "q, qd", a.options.radius, a.options.min_separation_rows);
    std::printf("training rows: %ld", static_cast<long>(train.rows()));
    if (test)
      std::printf(", test rows: %ld (%ld outside the training rows' box of velocities, accelerations and prismatic "
                  "positions)",
                  static_cast<long>(test->rows()), static_cast<long>(outside));
    std::printf("\n\n");
    print_table(columns, joints.size());
    for (const auto& [label, key, c] : columns)
      if (c.status != NeighbourConsistency::Status::Ok) std::printf("%s: %s\n", label.c_str(), rename_fields(c.message, cli_field_names()).c_str());
    if (test && columns[0].result.status == NeighbourConsistency::Status::Ok &&
        columns[2].result.status == NeighbourConsistency::Status::Ok) {
      const NeighbourConsistency &within = columns[0].result, &across = columns[2].result;
      // Only with neighbours for a good share of the test rows: a few pairs
      // describe atypical states, where the torque's own variation dominates.
      if (across.pairs * 5 >= across.queries)
        for (int j = 0; j < joints.size(); ++j)
          if (across.neighbour_nmse(j) >= 1.0 && across.neighbour_nmse(j) > 2.0 * within.neighbour_nmse(j))
            std::printf("joint %d: at states both logs visit, the test torque differs from the training torque by "
                        "more than its own variance (neighbour nMSE %.3g against %.3g within the training rows): the "
                        "test rows follow another function of the logged state (a payload, an offset, another "
                        "controller), which the training rows cannot teach any model.\n",
                        j + 1, across.neighbour_nmse(j), within.neighbour_nmse(j));
    }
    for (const auto& [label, key, c] : columns)
      if (c.status == NeighbourConsistency::Status::Ok && c.pairs * 5 < c.queries)
        std::printf("%s: only %ld of %ld rows have a neighbour; the numbers describe those states only.\n",
                    label.c_str(), c.pairs, c.queries);
  }
  if (!a.out.empty()) {
    write_file_atomically(a.out, [&](std::ostream& o) { o << report.dump(2) << "\n"; });
    if (!a.quiet) std::printf("wrote %s\n", a.out.c_str());
  }
  if (!a.plot.empty()) {
    const PlotResult p = render_plot("consistency", a.out, a.plot);
    if (!p.ok) {
      std::fprintf(stderr, "gipdyn: warning: %s\n", p.message.c_str());
      return kExitFailure;  // the numbers are written
    }
    if (!a.quiet) std::printf("wrote %s\n", a.plot.c_str());
  }
  return 0;
}

}  // namespace

Command add_inspect(CLI::App& app) {
  auto a = std::make_shared<InspectArgs>();
  add_data_option(app, a->data, a->mat_variable, a->columns, "Robot log: CSV with columns q1..qn, qd1..qdn, qdd1..qddn, tau1..taun");
  app.add_option("--joints", a->joints,
                 "Joint types, one R (revolute) or P (prismatic) per joint, e.g. RRRRRR (default: those the log's .json sidecar records, as simulate writes them; else required)");
  app.add_option("--train-rows", a->train_rows, "Training rows FIRST-LAST of --data (1-based data rows; default: all)");
  app.add_option("--test-rows", a->test_rows, "Test rows FIRST-LAST of --data, compared with the training rows");
  app.add_option("--test", a->test, "A test log (same layout) compared with the training rows")->check(CLI::ExistingFile);
  app.add_option("--radius", a->options.radius,
                 "Neighbours: standardised inputs (each divided by its training standard deviation) at most this far apart")
      ->capture_default_str();
  app.add_option("--min-separation-rows", a->options.min_separation_rows,
                 "Within one log, neighbours at least this many rows apart (two visits, not two samples of one)")
      ->capture_default_str();
  app.add_flag("--accelerations", a->options.use_accelerations,
               "Compare accelerations too (off: logged accelerations are often mostly noise)");
  app.add_option("--max-queries", a->options.max_queries,
                 "At most this many rows looked up, a constant-step subsample")
      ->capture_default_str();
  app.add_option("--out", a->out, "Write the report as JSON");
  app.add_option("--plot", a->plot, "Write a bar plot of the neighbour nMSE per joint (PNG; needs --out)");
  app.add_flag("--quiet", a->quiet, "Print nothing but errors and warnings");
  return [a]() -> int { return run_inspect(*a); };
}

}  // namespace gipdyn::cli
