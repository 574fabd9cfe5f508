#include "gipdyn/preprocess/log_preprocessing.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/preprocess/signal.hpp"

namespace gipdyn {
namespace {

std::vector<std::string> numbered(const std::string& prefix, int n) {
  std::vector<std::string> names;
  for (int j = 1; j <= n; ++j) names.push_back(prefix + std::to_string(j));
  return names;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

void PreprocessOptions::validate() const {
  if (dt < 0.0 || !std::isfinite(dt)) throw Error("PreprocessOptions::dt must be > 0 (or 0: the log's mean step)");
  if (cutoff_hz < 0.0 || !std::isfinite(cutoff_hz)) throw Error("PreprocessOptions::cutoff_hz must be > 0 Hz (or 0: no filter)");
  if (filter_order < 1 || filter_order > 10) throw Error("PreprocessOptions::filter_order must be 1..10");
  if (!(rest_velocity > 0.0)) throw Error("PreprocessOptions::rest_velocity must be > 0");
  if (!(rest_duration >= 0.0)) throw Error("PreprocessOptions::rest_duration must be >= 0");
  if (log_period < 0.0 || !std::isfinite(log_period)) throw Error("PreprocessOptions::log_period must be > 0 seconds");
  if (log_period > 0.0 && !time_column.empty())
    throw Error("PreprocessOptions::log_period is for logs without a time column; drop it or PreprocessOptions::time_column");
}

std::vector<std::string> PreprocessedLog::column_names() const {
  std::vector<std::string> names{"t"};
  for (const char* p : {"q", "qd", "qdd", "tau"})
    for (const auto& s : numbered(p, joints())) names.push_back(s);
  return names;
}

Eigen::MatrixXd PreprocessedLog::table() const {
  const int n = joints();
  Eigen::MatrixXd T(t.size(), 1 + 4 * n);
  T << t, q, qd, qdd, tau;
  return T;
}

PreprocessedLog preprocess_log(const std::string& path, const PreprocessOptions& o) {
  o.validate();
  const CsvHeader header = read_csv_header(path);
  int n = 0;
  while (header.has("q" + std::to_string(n + 1))) ++n;
  if (n == 0) throw Error("'" + path + "' has no column q1; name the joint positions q1, q2, ...");
  for (const auto& c : numbered("tau", n))
    if (!header.has(c))
      throw Error("'" + path + "' has q1..q" + std::to_string(n) + " but no column " + c +
                  "; the log needs one torque per joint");
  int qd_present = 0;
  for (const auto& c : numbered("qd", n)) qd_present += header.has(c);
  if (qd_present != 0 && qd_present != n)
    throw Error("'" + path + "' has " + std::to_string(qd_present) + " of the " + std::to_string(n) +
                " velocity columns qd1..qd" + std::to_string(n) + "; give all or none (none: computed from q)");
  const bool has_qd = qd_present == n;
  std::string time_column = o.time_column;
  if (time_column.empty() && o.log_period == 0.0) time_column = header.has("t") ? "t" : "time";
  if (!time_column.empty() && !header.has(time_column))
    throw Error("'" + path + "' has no time column '" + time_column +
                "'; name it with PreprocessOptions::time_column, or give PreprocessOptions::log_period if its rows are equally spaced");

  std::vector<std::string> columns;
  if (!time_column.empty()) columns.push_back(time_column);
  for (const auto& c : numbered("q", n)) columns.push_back(c);
  if (has_qd)
    for (const auto& c : numbered("qd", n)) columns.push_back(c);
  for (const auto& c : numbered("tau", n)) columns.push_back(c);
  Eigen::MatrixXd raw = read_csv_columns(path, columns);
  const Eigen::Index rows = raw.rows();
  if (rows < 3) throw Error("'" + path + "' has " + std::to_string(rows) + " samples; at least 3 are needed");
  if (time_column.empty()) {  // rows log_period apart, from t = 0
    Eigen::MatrixXd with_time(rows, raw.cols() + 1);
    with_time << o.log_period * Eigen::VectorXd::LinSpaced(rows, 0.0, static_cast<double>(rows - 1)), raw;
    raw = std::move(with_time);
  }
  const Eigen::VectorXd t = raw.col(0);
  std::vector<double> steps;
  for (Eigen::Index i = 1; i < rows; ++i) {
    if (!(t(i) > t(i - 1)))
      throw Error("'" + path + "': time does not increase at data row " + std::to_string(i + 1) + " (" +
                  std::to_string(t(i - 1)) + " then " + std::to_string(t(i)) + "); sort the log or remove duplicates");
    steps.push_back(t(i) - t(i - 1));
  }
  const double median_step = median(steps);
  // Default: the mean step, so that a log already on a uniform grid keeps its
  // samples (the median step, off by rounding, could lose the last one).
  const double mean_step = (t(rows - 1) - t(0)) / static_cast<double>(rows - 1);
  const double dt = o.dt > 0.0 ? o.dt : mean_step;
  nlohmann::json report;
  report["input"] = path;
  report["joints"] = n;
  report["time_column"] = time_column.empty() ? "none: rows " + std::to_string(o.log_period) + " s apart (log_period)"
                                              : time_column;
  report["input_rows"] = rows;
  report["input_time_span_s"] = {t(0), t(rows - 1)};
  report["input_step_s"] = {{"mean", mean_step},
                            {"median", median_step},
                            {"min", *std::min_element(steps.begin(), steps.end())},
                            {"max", *std::max_element(steps.begin(), steps.end())}};
  nlohmann::json steps_done = nlohmann::json::array();

  // 1. Uniform grid t0 + k dt within the log's span.
  // The tolerance keeps the last sample of an already uniform log despite rounding.
  const Eigen::Index m = static_cast<Eigen::Index>(std::floor((t(rows - 1) - t(0)) / dt + 1e-9)) + 1;
  if (m < 3) throw Error("PreprocessOptions::dt " + std::to_string(dt) + " s leaves fewer than 3 samples in the log's span");
  const Eigen::VectorXd grid =
      (t(0) + dt * Eigen::VectorXd::LinSpaced(m, 0.0, static_cast<double>(m - 1)).array()).cwiseMin(t(rows - 1));
  const Eigen::MatrixXd data = resample_linear(t, raw.rightCols(raw.cols() - 1), grid);
  steps_done.push_back({{"step", "resample"},
                        {"method", "linear interpolation onto t0 + k dt"},
                        {"dt_s", dt},
                        {"dt_source", o.dt > 0.0 ? "dt option" : "mean step of the log"},
                        {"rows", m}});

  PreprocessedLog out;
  out.t = grid;
  out.q = data.leftCols(n);
  if (has_qd) out.qd = data.middleCols(n, n);
  out.tau = data.rightCols(n);

  // 2. Zero-phase low-pass.
  if (o.cutoff_hz > 0.0) {
    const auto sections = butterworth_lowpass(o.filter_order, o.cutoff_hz, 1.0 / dt);
    out.q = filtfilt(sections, out.q);
    if (has_qd) out.qd = filtfilt(sections, out.qd);
    out.tau = filtfilt(sections, out.tau);
    steps_done.push_back({{"step", "low-pass"},
                          {"filter", "Butterworth, forward and backward (zero phase)"},
                          {"order_per_pass", o.filter_order},
                          {"cutoff_hz", o.cutoff_hz},
                          {"gain_at_cutoff", 0.5},
                          {"edges", "odd extension by " + std::to_string(filtfilt_padding(sections)) +
                                        " samples, steady-state initial conditions"},
                          {"applied_to", has_qd ? nlohmann::json{"q", "qd", "tau"} : nlohmann::json{"q", "tau"}}});
  }

  // 3. Derivatives.
  const std::string filtered = o.cutoff_hz > 0.0 ? "filtered " : "";
  if (!has_qd) out.qd = time_derivative(out.q, dt);
  out.qdd = time_derivative(out.qd, dt);
  steps_done.push_back(
      {{"step", "derivatives"},
       {"method", "second-order central differences (one-sided at the ends)"},
       {"qd", has_qd ? "from the log" + std::string(o.cutoff_hz > 0.0 ? ", filtered" : "")
                     : "d/dt of the " + filtered + "q"},
       {"qdd", "d/dt of the " + filtered + "qd" + std::string(header.has("qdd1") ? " (the log's qdd columns are ignored)" : "")}});

  // 4. Stretches at rest carry no information about inertia and make friction
  // ambiguous. A turning point also has qd = 0, but only for an instant: only
  // runs lasting at least rest_duration count as rest.
  if (o.drop_rest) {
    const Eigen::Index rows_now = out.t.size();
    std::vector<bool> still(static_cast<size_t>(rows_now));
    for (Eigen::Index i = 0; i < rows_now; ++i)
      still[static_cast<size_t>(i)] = out.qd.row(i).cwiseAbs().maxCoeff() < o.rest_velocity;
    std::vector<Eigen::Index> keep;
    Eigen::Index stretches = 0;
    for (Eigen::Index i = 0; i < rows_now;) {
      Eigen::Index end = i;
      while (end < rows_now && still[static_cast<size_t>(end)]) ++end;
      if (end == i) {
        keep.push_back(i++);
        continue;
      }
      const bool long_enough = static_cast<double>(end - i) * dt >= o.rest_duration - 1e-12;
      stretches += long_enough;
      for (; i < end; ++i)
        if (!long_enough) keep.push_back(i);
    }
    const Eigen::Index dropped = rows_now - static_cast<Eigen::Index>(keep.size());
    if (keep.size() < 3)
      throw Error("PreprocessOptions::drop_rest would leave " + std::to_string(keep.size()) + " samples: every |qd| is below " +
                  std::to_string(o.rest_velocity) + "; lower PreprocessOptions::rest_velocity");
    out.t = out.t(keep).eval();
    out.q = out.q(keep, Eigen::all).eval();
    out.qd = out.qd(keep, Eigen::all).eval();
    out.qdd = out.qdd(keep, Eigen::all).eval();
    out.tau = out.tau(keep, Eigen::all).eval();
    steps_done.push_back({{"step", "drop-rest"},
                          {"rule", "drop every stretch of at least rest_duration_s where all |qd_j| < rest_velocity"},
                          {"rest_velocity", o.rest_velocity},
                          {"rest_duration_s", o.rest_duration},
                          {"stretches_dropped", stretches},
                          {"dropped_rows", dropped}});
  }
  report["steps"] = steps_done;
  report["output_rows"] = out.t.size();
  out.report = report;
  return out;
}

}  // namespace gipdyn
