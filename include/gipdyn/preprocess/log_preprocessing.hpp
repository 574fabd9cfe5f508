#pragma once
// From a raw robot log to a training dataset (`gipdyn preprocess`):
//   0. optionally cut the log into segments (e.g. train / test rows), each
//      processed on its own so that no filter carries one into the other;
//   1. resample onto a uniform time grid (linear interpolation);
//   2. Butterworth low-pass of q and qd (when logged), and of tau only if asked:
//      zero phase (forward and backward), or causal (forward only, as a
//      controller can run it online, with its delay reported);
//   3. qd = d/dt of the filtered q when the log has no velocities, and always
//      qdd = d/dt of the filtered qd (a logged qdd is ignored): central
//      differences, or backward differences when causal;
//   4. optionally drop the stretches at rest.
// Every step and its effect goes into a report (the sidecar JSON).
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/io/log_columns.hpp"

namespace gipdyn {

struct PreprocessOptions {
  LogColumns columns;          // what the log calls q1.., qd1.., tau1.. (a qdd column is ignored: recomputed)
  std::string time_column;     // "": "t", else "time"
  double log_period = 0.0;     // > 0: the log has no time column, its rows are this many seconds apart
  double dt = 0.0;             // resampling period (s); 0: the log's mean step
  double cutoff_hz = 0.0;      // low-pass cutoff (Hz); 0: no filtering
  int filter_order = 2;        // Butterworth order of one pass (the zero-phase filter doubles it)
  bool causal = false;         // forward-only filter and backward differences (online use)
  bool filter_torque = false;  // low-pass tau too (the targets are left as measured otherwise)
  // 1-based data rows of the log at which a new segment starts (increasing, > 1).
  std::vector<long> segment_starts;
  // A step between two rows of one segment longer than this many median steps
  // is a gap (a pause in logging): interpolating across it would invent data,
  // so it is an error naming the row where a segment should start.
  double max_gap_steps = 10.0;
  bool drop_rest = false;
  double rest_velocity = 0.01; // at rest: every |qd_j| below this (rad/s or m/s) ...
  double rest_duration = 0.1;  // ... for at least this long (s), unlike a turning point
  void validate() const;       // throws gipdyn::Error naming the option
};

struct PreprocessedLog {
  Eigen::VectorXd t;
  Eigen::MatrixXd q, qd, qdd, tau;  // rows x joints
  nlohmann::json report;
  int joints() const { return static_cast<int>(q.cols()); }
  // t, q1..qn, qd1..qn, qdd1..qn, tau1..taun: the dataset layout of `gipdyn train`.
  std::vector<std::string> column_names() const;
  Eigen::MatrixXd table() const;
};

// Reads the log (columns q1..qn and tau1..taun, optionally qd1..qn, and a time
// column) and applies the steps above. Throws gipdyn::Error naming the problem.
PreprocessedLog preprocess_log(const std::string& path, const PreprocessOptions& options);

}  // namespace gipdyn
