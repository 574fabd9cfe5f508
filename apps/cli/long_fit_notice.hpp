#pragma once
// An exact GP on a long log costs O(N^3) per NLL evaluation. Timed on a
// joint's first evaluation (or its first two), a fit that will take long says so at once,
// with what makes it fast, instead of leaving the user to work it out from
// the progress lines.
#include <chrono>
#include <map>
#include <string>
#include <utility>

#include "gipdyn/progress.hpp"

namespace gipdyn::cli {

// The note to print before an exact GP learns its hyperparameters on `rows`
// rows (exact_hyperparameter_rows); "" below kLongExactFitRows. The timed
// estimate follows (LongFitNotice).
std::string long_exact_fit_note(long rows);

class LongFitNotice {
 public:
  using Clock = std::chrono::steady_clock;
  // Where the joints outnumber the ones that train at once
  // (joints_trained_at_once), they train in waves.
  LongFitNotice(int joints, int joints_at_once);
  // The note to print, once per fit, when a joint's first evaluation (timed
  // from the start of its work) or the gap between its first two shows that
  // its fit will take ten minutes or more; "" otherwise.
  std::string observe(const ProgressEvent& e, Clock::time_point now = Clock::now());

 private:
  std::string note(double seconds_per_evaluation, long rows);

  int waves_ = 1;
  bool said_ = false;
  // When each (joint, rows) stage's first evaluation came.
  std::map<std::pair<int, long>, Clock::time_point> first_;
};

}  // namespace gipdyn::cli
