#pragma once
// One progress interface for all long work: the optimiser, GP training,
// network training and the applications built on them report ProgressEvents
// through the same callback type. Each layer fills in what it knows (the
// optimiser the iteration, training the joint and restart) and passes the
// event up; front ends decide what to print and how often.
#include <functional>
#include <limits>
#include <string>

namespace gipdyn {

struct ProgressEvent {
  std::string estimator;  // "gip", "nn", ... (empty where unknown)
  int joint = -1;         // 0-based; -1 for work that is not per joint
  int restart = 0;        // 0: the data-driven start
  long rows = 0;          // training rows the objective is computed on (0: not stated)
  int iteration = 0;      // optimiser evaluation or step, or training epoch
  double objective = std::numeric_limits<double>::quiet_NaN();  // NLL or training loss
  double grad_norm = std::numeric_limits<double>::quiet_NaN();  // projected, infinity norm
  double seconds = 0.0;   // since the start of this joint's (or this fit's) work
  bool finished = false;  // the last event of a joint or of a whole fit
  std::string message;    // why it finished, or a free-form note from an application
};

// May be called from worker threads: the callback must be thread-safe.
using ProgressCallback = std::function<void(const ProgressEvent&)>;

// Sends a note (an event of iteration 0, which front ends print as it comes):
// what a long step without iterations is doing. Nothing without a callback.
void send_note(const ProgressCallback& progress, const std::string& estimator, const std::string& message);

// One line describing the event, e.g. "gip joint 2 on 500 rows restart 1 iteration 40: NLL -1234.5 |grad| 0.012 (3.1 s)".
std::string describe(const ProgressEvent& event);

}  // namespace gipdyn
