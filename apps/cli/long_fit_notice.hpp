#pragma once
// An exact GP on a long log costs O(N^3) per NLL evaluation. Timed on a
// joint's first two evaluations, a fit that will take long says so at once,
// with what makes it fast, instead of leaving the user to work it out from
// the progress lines.
#include <chrono>
#include <map>
#include <string>
#include <utility>

#include "gipdyn/progress.hpp"

namespace gipdyn::cli {

class LongFitNotice {
 public:
  using Clock = std::chrono::steady_clock;
  // Where the joints outnumber the ones that train at once, they train in waves.
  LongFitNotice(int joints, int threads);
  // The note to print, once per fit, on the second evaluation of the first
  // joint whose fit will take ten minutes or more; "" otherwise.
  std::string observe(const ProgressEvent& e, Clock::time_point now = Clock::now());

 private:
  int waves_ = 1;
  bool said_ = false;
  std::map<std::pair<int, long>, Clock::time_point> first_;
};

}  // namespace gipdyn::cli
