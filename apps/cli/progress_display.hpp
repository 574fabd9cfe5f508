#pragma once
// What train shows while it fits. On a terminal: one line per joint, rewritten
// in place (the joint's latest iteration, or how it finished), under a line
// with the elapsed time and an estimate of what is left; notes (a teacher's
// fit, a candidate's score) scroll above. Elsewhere (a log file, a pipe):
// plain lines, a sample of the iterations and every joint's end, each end with
// the same estimate.
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "gipdyn/progress.hpp"

namespace gipdyn::cli {

class ProgressDisplay {
 public:
  using Clock = std::chrono::steady_clock;
  // joints: how many joints a fit has; terminal: rewrite lines in place (else plain lines).
  ProgressDisplay(std::FILE* out, int joints, bool terminal);
  // Thread-safe: the optimiser reports from worker threads.
  void observe(const ProgressEvent& e, Clock::time_point now = Clock::now());
  // A line of the caller's, above the block.
  void note(const std::string& line);
  // Ends the block in place, so that what follows prints below it.
  void finish();

  // "2 of 6 joints done, 41 s elapsed, about 1.4 min left", without an
  // estimate before the first joint ends: the joints left times the time per
  // finished joint so far (joints that train at once share that time).
  static std::string summary(int done, int joints, double elapsed_seconds);

 private:
  void start_block(const std::string& estimator, Clock::time_point now);
  void end_block();
  void redraw(Clock::time_point now);
  void print_plain(const std::string& line, Clock::time_point now);
  int joints_done() const;

  std::FILE* out_;
  int joints_;
  bool terminal_;
  std::mutex mu_;
  std::string estimator_;          // the fit the block shows
  Clock::time_point block_start_;
  std::vector<std::string> lines_; // one per joint
  std::vector<bool> done_;
  int drawn_ = 0;                  // lines of the block on the screen
  Clock::time_point last_draw_;
};

}  // namespace gipdyn::cli
