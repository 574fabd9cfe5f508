#include "gipdyn/preprocess/log_preprocessing.hpp"

#include <cstdio>
#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
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

// What the segments did, summed for the report.
struct SegmentCounts {
  Eigen::Index resampled = 0, dropped = 0, rest_stretches = 0;
  std::vector<Eigen::Index> unwrapped;  // per joint: jumps of q taken back by 2 pi
};

// 0. An angle logged within (-pi, pi] (ROS joint_states of a continuous joint,
// many controllers' wrist) jumps by about 2 pi when it wraps. No joint moves
// pi rad (or m) between two samples, so such a jump is a wrap: undone from
// there on, before resampling and differentiation turn it into a velocity
// spike of 2 pi / dt. The joint's angle then runs on continuously.
void unwrap_positions(Eigen::Ref<Eigen::MatrixXd> q, SegmentCounts& counts) {
  const double two_pi = 2.0 * M_PI;
  for (Eigen::Index j = 0; j < q.cols(); ++j) {
    double shift = 0.0;
    for (Eigen::Index i = 1; i < q.rows(); ++i) {
      const double step = q(i, j) + shift - q(i - 1, j);
      if (std::abs(step) > 0.5 * two_pi) {
        shift -= two_pi * std::round(step / two_pi);
        ++counts.unwrapped[static_cast<size_t>(j)];
      }
      q(i, j) += shift;
    }
  }
}

// 4. Stretches at rest carry no information about inertia and make friction
// ambiguous. A turning point also has qd = 0, but only for an instant: only
// runs lasting at least rest_duration count as rest.
void drop_rest_stretches(PreprocessedLog& part, const PreprocessOptions& o, double dt, SegmentCounts& counts) {
  const Eigen::Index rows_now = part.t.size();
  std::vector<bool> still(static_cast<size_t>(rows_now));
  for (Eigen::Index i = 0; i < rows_now; ++i)
    still[static_cast<size_t>(i)] = part.qd.row(i).cwiseAbs().maxCoeff() < o.rest_velocity;
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < rows_now;) {
    Eigen::Index end_run = i;
    while (end_run < rows_now && still[static_cast<size_t>(end_run)]) ++end_run;
    if (end_run == i) {
      keep.push_back(i++);
      continue;
    }
    const bool long_enough = static_cast<double>(end_run - i) * dt >= o.rest_duration - 1e-12;
    counts.rest_stretches += long_enough;
    for (; i < end_run; ++i)
      if (!long_enough) keep.push_back(i);
  }
  counts.dropped += rows_now - static_cast<Eigen::Index>(keep.size());
  part.t = part.t(keep).eval();
  part.q = part.q(keep, Eigen::all).eval();
  part.qd = part.qd(keep, Eigen::all).eval();
  part.qdd = part.qdd(keep, Eigen::all).eval();
  part.tau = part.tau(keep, Eigen::all).eval();
}

// Steps 1-4 on one segment: times ts and the log's value columns (q, [qd,] tau).
PreprocessedLog process_segment(const Eigen::VectorXd& ts, const Eigen::MatrixXd& values, int n, bool has_qd,
                                double dt, const std::vector<Biquad>& sections, const PreprocessOptions& o,
                                SegmentCounts& counts) {
  // 1. Uniform grid t0 + k dt within the segment's span.
  // The tolerance keeps the last sample of an already uniform log despite rounding.
  const Eigen::Index m = static_cast<Eigen::Index>(std::floor((ts(ts.size() - 1) - ts(0)) / dt + 1e-9)) + 1;
  if (m < 3) throw Error("PreprocessOptions::dt " + std::to_string(dt) + " s leaves fewer than 3 samples in the span");
  const Eigen::VectorXd grid =
      (ts(0) + dt * Eigen::VectorXd::LinSpaced(m, 0.0, static_cast<double>(m - 1)).array()).cwiseMin(ts(ts.size() - 1));
  Eigen::MatrixXd unwrapped = values;
  unwrap_positions(unwrapped.leftCols(n), counts);
  const Eigen::MatrixXd data = resample_linear(ts, unwrapped, grid);
  counts.resampled += m;
  PreprocessedLog part;
  part.t = grid;
  part.q = data.leftCols(n);
  if (has_qd) part.qd = data.middleCols(n, n);
  part.tau = data.rightCols(n);
  // 2. Low-pass.
  if (o.cutoff_hz > 0.0) {
    auto filter = [&](const Eigen::MatrixXd& x) { return o.causal ? causal_filter(sections, x) : filtfilt(sections, x); };
    part.q = filter(part.q);
    if (has_qd) part.qd = filter(part.qd);
    if (o.filter_torque) part.tau = filter(part.tau);
  }
  // 3. Derivatives.
  auto derive = [&](const Eigen::MatrixXd& x) { return o.causal ? backward_derivative(x, dt) : time_derivative(x, dt); };
  if (!has_qd) part.qd = derive(part.q);
  part.qdd = derive(part.qd);
  if (o.drop_rest) drop_rest_stretches(part, o, dt, counts);
  return part;
}

// The segments one after the other.
PreprocessedLog concatenate(const std::vector<PreprocessedLog>& parts, int n) {
  Eigen::Index total = 0;
  for (const auto& part : parts) total += part.t.size();
  PreprocessedLog out;
  out.t.resize(total);
  for (Eigen::MatrixXd* m : {&out.q, &out.qd, &out.qdd, &out.tau}) m->resize(total, n);
  Eigen::Index row = 0;
  for (const auto& part : parts) {
    const Eigen::Index k = part.t.size();
    out.t.segment(row, k) = part.t;
    out.q.middleRows(row, k) = part.q;
    out.qd.middleRows(row, k) = part.qd;
    out.qdd.middleRows(row, k) = part.qdd;
    out.tau.middleRows(row, k) = part.tau;
    row += k;
  }
  return out;
}

}  // namespace

void PreprocessOptions::validate() const {
  columns.validate();
  if (dt < 0.0 || !std::isfinite(dt)) throw Error("PreprocessOptions::dt must be > 0 (or 0: the log's mean step)");
  if (cutoff_hz < 0.0 || !std::isfinite(cutoff_hz)) throw Error("PreprocessOptions::cutoff_hz must be > 0 Hz (or 0: no filter)");
  if (filter_order < 1 || filter_order > 10) throw Error("PreprocessOptions::filter_order must be 1..10");
  if (!(rest_velocity > 0.0)) throw Error("PreprocessOptions::rest_velocity must be > 0");
  if (!(rest_duration >= 0.0)) throw Error("PreprocessOptions::rest_duration must be >= 0");
  if (log_period < 0.0 || !std::isfinite(log_period)) throw Error("PreprocessOptions::log_period must be > 0 seconds");
  if (!(max_gap_steps > 1.0)) throw Error("PreprocessOptions::max_gap_steps must be > 1 (median steps)");
  for (size_t k = 0; k < segment_starts.size(); ++k)
    if (segment_starts[k] < 2 || (k > 0 && segment_starts[k] <= segment_starts[k - 1]))
      throw Error("PreprocessOptions::segment_starts must be increasing data rows > 1 (where a new segment begins)");
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

namespace {

// A log's columns as read, with its times (one per row, from its time column
// or PreprocessOptions::log_period) checked to increase at a rate of seconds.
struct RawLog {
  int joints = 0;
  bool has_qd = false, has_qdd = false;  // qd1..qdn given; qdd1 given (and ignored)
  std::string time_column;               // empty: rows log_period apart
  Eigen::MatrixXd table;                 // t, q, [qd,] tau
  Eigen::VectorXd t;
  std::vector<double> steps;             // t(i) - t(i - 1)
  double median_step = 0.0;
};

RawLog read_raw_log(const std::string& path, const PreprocessOptions& o) {
  const CsvHeader header = read_csv_header(path, o.columns);
  require_joints_counted_from_one(header, path);
  const int n = joint_column_count(header);
  if (n == 0)
    throw Error("'" + path + "' has no column " + o.columns.log_name("q", 1) +
                "; name the joint positions q1, q2, ..., or say what the log calls them (LogColumns, e.g. "
                "q=position_{i0})");
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
  Eigen::MatrixXd raw = read_csv_columns(path, columns, o.columns);
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
  // A robot log sampled less than once a second holds no accelerations; such a
  // step is nearly always a time column in milli-, micro- or nanoseconds.
  if (!time_column.empty() && median_step > 1.0) {
    char step[32];
    std::snprintf(step, sizeof step, "%.6g", median_step);
    throw Error("'" + path + "': its time column '" + time_column + "' advances by " + step +
                " per row (median), read as seconds; if it counts milli-, micro- or nanoseconds, divide it by 1e3, "
                "1e6 or 1e9 (or give PreprocessOptions::log_period instead)");
  }
  RawLog log;
  log.joints = n;
  log.has_qd = has_qd;
  log.has_qdd = header.has("qdd1");
  log.time_column = time_column;
  log.table = std::move(raw);
  log.t = t;
  log.steps = std::move(steps);
  log.median_step = median_step;
  return log;
}

// The segments of a log of `rows` rows: [first, end) data rows, 0-based, split at PreprocessOptions::segment_starts.
std::vector<std::pair<Eigen::Index, Eigen::Index>> log_segments(const PreprocessOptions& o, Eigen::Index rows) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> segments;
  Eigen::Index first = 0;
  for (long start : o.segment_starts) {
    if (start > rows)
      throw Error("PreprocessOptions::segment_starts: row " + std::to_string(start) + " is past the log's " +
                  std::to_string(rows) + " data rows");
    segments.emplace_back(first, start - 1);
    first = start - 1;
  }
  segments.emplace_back(first, rows);
  return segments;
}

// The report's "steps": what was done to the log, in order, with the rules and counts.
nlohmann::json processing_steps(const PreprocessOptions& o, const RawLog& log, const SegmentCounts& counts, double dt,
                                const std::vector<Biquad>& sections) {
  const int n = log.joints;
  const bool has_qd = log.has_qd;
  nlohmann::json steps_done = nlohmann::json::array();
  nlohmann::json jumps = nlohmann::json::object();
  for (int j = 0; j < n; ++j)
    if (counts.unwrapped[static_cast<size_t>(j)] > 0) jumps["q" + std::to_string(j + 1)] = counts.unwrapped[static_cast<size_t>(j)];
  if (!jumps.empty())
    steps_done.push_back({{"step", "unwrap"},
                          {"rule", "a change of more than pi between two rows of a segment is an angle wrapping "
                                   "around: a multiple of 2 pi is taken back from there on"},
                          {"jumps", jumps}});
  steps_done.push_back({{"step", "resample"},
                        {"method", "linear interpolation onto t0 + k dt"},
                        {"dt_s", dt},
                        {"dt_source", o.dt > 0.0 ? "dt option" : "mean step of the log"},
                        {"rows", counts.resampled}});
  const double delay = o.cutoff_hz > 0.0 && o.causal ? dc_group_delay_samples(sections) : 0.0;
  if (o.cutoff_hz > 0.0) {
    nlohmann::json applied = has_qd ? nlohmann::json{"q", "qd"} : nlohmann::json{"q"};
    if (o.filter_torque) applied.push_back("tau");
    nlohmann::json step = {{"step", "low-pass"},
                           {"order_per_pass", o.filter_order},
                           {"cutoff_hz", o.cutoff_hz},
                           {"applied_to", applied}};
    if (o.causal) {
      step["filter"] = "Butterworth, forward only (causal)";
      step["gain_at_cutoff"] = std::sqrt(0.5);
      step["delay_s"] = delay * dt;
      step["delay_note"] = "group delay at low frequency; tau is " +
                           std::string(o.filter_torque ? "delayed alike" : "not filtered, so q and qd lag it by this much");
      step["start"] = "steady state of the first sample";
    } else {
      step["filter"] = "Butterworth, forward and backward (zero phase)";
      step["gain_at_cutoff"] = 0.5;
      step["edges"] = "odd extension by " + std::to_string(filtfilt_padding(sections)) +
                      " samples, steady-state initial conditions";
    }
    steps_done.push_back(step);
  }
  const std::string filtered = o.cutoff_hz > 0.0 ? "filtered " : "";
  nlohmann::json derivatives = {
      {"step", "derivatives"},
      {"method", o.causal ? "backward differences (causal, half a sample of delay each; the first row is 0)"
                          : "second-order central differences (one-sided at the ends)"},
      {"qd", has_qd ? "from the log" + std::string(o.cutoff_hz > 0.0 ? ", filtered" : "") : "d/dt of the " + filtered + "q"},
      {"qdd", "d/dt of the " + filtered + "qd" +
                  std::string(log.has_qdd ? " (the log's qdd columns are ignored)" : "")}};
  if (o.causal)
    derivatives["delay_s"] = {{"q", delay * dt},
                              {"qd", (delay + (has_qd ? 0.0 : 0.5)) * dt},
                              {"qdd", (delay + (has_qd ? 0.5 : 1.0)) * dt}};
  steps_done.push_back(derivatives);
  if (o.drop_rest)
    steps_done.push_back({{"step", "drop-rest"},
                          {"rule", "drop every stretch of at least rest_duration_s where all |qd_j| < rest_velocity"},
                          {"rest_velocity", o.rest_velocity},
                          {"rest_duration_s", o.rest_duration},
                          {"stretches_dropped", counts.rest_stretches},
                          {"dropped_rows", counts.dropped}});
  return steps_done;
}

}  // namespace

PreprocessedLog preprocess_log(const std::string& path, const PreprocessOptions& o) {
  o.validate();
  const RawLog log = read_raw_log(path, o);
  const int n = log.joints;
  const Eigen::MatrixXd& raw = log.table;
  const Eigen::VectorXd& t = log.t;
  const Eigen::Index rows = raw.rows();
  const double median_step = log.median_step;
  const std::vector<std::pair<Eigen::Index, Eigen::Index>> segments = log_segments(o, rows);
  // Default: the mean step within segments (the pause between two segments is not
  // a sampling step), so that a log already on a uniform grid keeps its samples
  // (the median step, off by rounding, could lose the last one).
  double span = 0.0;
  Eigen::Index spanned_steps = 0;
  for (const auto& [a, b] : segments) {
    span += t(b - 1) - t(a);
    spanned_steps += b - 1 - a;
  }
  const double mean_step = spanned_steps > 0 ? span / static_cast<double>(spanned_steps) : median_step;
  const double dt = o.dt > 0.0 ? o.dt : mean_step;
  nlohmann::json report;
  report["input"] = path;
  report["joints"] = n;
  report["time_column"] = log.time_column.empty()
                              ? "none: rows " + std::to_string(o.log_period) + " s apart (log_period)"
                              : log.time_column;
  report["input_rows"] = rows;
  report["input_time_span_s"] = {t(0), t(rows - 1)};
  report["input_step_s"] = {{"mean", mean_step},
                            {"median", median_step},
                            {"min", *std::min_element(log.steps.begin(), log.steps.end())},
                            {"max", *std::max_element(log.steps.begin(), log.steps.end())}};

  for (const auto& [a, b] : segments)
    for (Eigen::Index i = a + 1; i < b; ++i)
      if (t(i) - t(i - 1) > o.max_gap_steps * median_step)
        throw Error("'" + path + "' has a gap of " + std::to_string(t(i) - t(i - 1)) + " s before data row " +
                    std::to_string(i + 1) + " (the median step is " + std::to_string(median_step) +
                    " s); start a segment there (PreprocessOptions::segment_starts " + std::to_string(i + 1) +
                    ") or raise PreprocessOptions::max_gap_steps");
  nlohmann::json segment_report = nlohmann::json::array();
  std::vector<Biquad> sections;
  if (o.cutoff_hz > 0.0) sections = butterworth_lowpass(o.filter_order, o.cutoff_hz, 1.0 / dt);
  std::vector<PreprocessedLog> parts;
  SegmentCounts counts;
  counts.unwrapped.assign(static_cast<size_t>(n), 0);
  for (const auto& [a, b] : segments) {
    const std::string where = segments.size() > 1 ? " (segment of data rows " + std::to_string(a + 1) + "-" +
                                                        std::to_string(b) + ")"
                                                  : "";
    try {
      parts.push_back(process_segment(t.segment(a, b - a), raw.block(a, 1, b - a, raw.cols() - 1), n, log.has_qd, dt,
                                      sections, o, counts));
    } catch (const Error& e) {
      if (where.empty()) throw;
      throw Error(std::string(e.what()) + where);
    }
    segment_report.push_back({{"input_rows", {a + 1, b}}, {"output_rows", parts.back().t.size()}});
  }
  PreprocessedLog out = concatenate(parts, n);
  if (o.drop_rest && out.t.size() < 3)
    throw Error("PreprocessOptions::drop_rest would leave " + std::to_string(out.t.size()) +
                " samples: every |qd| is below " + std::to_string(o.rest_velocity) +
                "; lower PreprocessOptions::rest_velocity");

  if (segments.size() > 1) report["segments"] = segment_report;
  report["steps"] = processing_steps(o, log, counts, dt, sections);
  report["dt_s"] = dt;
  report["output_rows"] = out.t.size();
  out.report = report;
  return out;
}

}  // namespace gipdyn
