#include "long_fit_notice.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "reports/text_format.hpp"

namespace gipdyn::cli {

namespace {

const char* const kFasterOptions =
    "For a log this long, --hyperparameter-rows 2000 learns the hyperparameters on a subsample and conditions the "
    "model on every row, and --inducing 500 makes every evaluation O(N M^2) (docs/training.md, \"Long logs\")";

}  // namespace

std::string long_exact_fit_note(long rows) {
  const std::string warning = long_exact_fit_warning(rows);
  if (warning.empty()) return "";
  return "note: " + warning + ". An estimate follows the first evaluation. " + kFasterOptions;
}

LongFitNotice::LongFitNotice(int joints, int joints_at_once) {
  const int parallel = std::max(1, joints_at_once);
  waves_ = (joints + parallel - 1) / parallel;
}

std::string LongFitNotice::observe(const ProgressEvent& e, Clock::time_point now) {
  if (said_ || e.finished || e.joint < 0 || e.rows <= 0) return "";
  if (e.iteration == 1) {
    // A joint's very first evaluation, timed from the start of its work (which
    // adds only O(N) setup to the O(N^3) evaluation): on a long log that is
    // minutes sooner than waiting for the second.
    const auto earlier = first_.lower_bound({e.joint, std::numeric_limits<long>::min()});
    const bool first_of_joint = earlier == first_.end() || earlier->first.first != e.joint;
    first_[{e.joint, e.rows}] = now;
    return first_of_joint && e.restart == 0 ? note(e.seconds, e.rows) : "";
  }
  const auto it = first_.find({e.joint, e.rows});
  if (e.iteration != 2 || it == first_.end()) return "";
  return note(std::chrono::duration<double>(now - it->second).count(), e.rows);
}

std::string LongFitNotice::note(double per_evaluation, long rows) {
  // 80-300 evaluations a joint: the range of docs/results/training.md's fits.
  const double low = 80.0 * per_evaluation * waves_, high = 300.0 * per_evaluation * waves_;
  if (!(low >= 600.0)) return "";
  said_ = true;
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "note: %.1f s per NLL evaluation on %ld rows, and a joint usually needs 80-300, so this fit may take "
                "%s to %s. %s",
                per_evaluation, rows, duration(low).c_str(), duration(high).c_str(), kFasterOptions);
  return buf;
}

}  // namespace gipdyn::cli
