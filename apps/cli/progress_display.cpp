#include "progress_display.hpp"

#include <algorithm>
#include <cmath>

namespace gipdyn::cli {
namespace {

// A terminal is redrawn at most this often: the optimiser reports every evaluation.
constexpr std::chrono::milliseconds kRedrawInterval{100};
// Off a terminal, one iteration in this many is printed.
constexpr int kPlainIterationStep = 10;

std::string duration_text(double seconds) {
  char buf[32];
  if (seconds < 90.0)
    std::snprintf(buf, sizeof buf, "%.0f s", std::max(0.0, seconds));
  else if (seconds < 5400.0)
    std::snprintf(buf, sizeof buf, "%.1f min", seconds / 60.0);
  else
    std::snprintf(buf, sizeof buf, "%.1f h", seconds / 3600.0);
  return buf;
}

}  // namespace

ProgressDisplay::ProgressDisplay(std::FILE* out, int joints, bool terminal)
    : out_(out), joints_(std::max(1, joints)), terminal_(terminal) {}

std::string ProgressDisplay::summary(int done, int joints, double elapsed_seconds) {
  std::string text = std::to_string(done) + " of " + std::to_string(joints) + " joints done, " +
                     duration_text(elapsed_seconds) + " elapsed";
  if (done > 0 && done < joints)
    text += ", about " + duration_text(elapsed_seconds * (joints - done) / done) + " left";
  return text;
}

void ProgressDisplay::start_block(const std::string& estimator, Clock::time_point now) {
  end_block();
  estimator_ = estimator;
  block_start_ = now;
  lines_.assign(static_cast<size_t>(joints_), "waiting");
  done_.assign(static_cast<size_t>(joints_), false);
}

void ProgressDisplay::end_block() {
  drawn_ = 0;  // the block stays where it is; what follows prints below it
  estimator_.clear();
}

void ProgressDisplay::finish() {
  std::lock_guard<std::mutex> lock(mu_);
  end_block();
}

void ProgressDisplay::note(const std::string& line) {
  std::lock_guard<std::mutex> lock(mu_);
  print_plain(line, Clock::now());
}

void ProgressDisplay::print_plain(const std::string& line, Clock::time_point now) {
  const bool above_the_block = terminal_ && drawn_ > 0;  // clear the block, print, redraw it below
  if (above_the_block) std::fprintf(out_, "\x1b[%dA\x1b[J", drawn_);
  drawn_ = 0;
  std::fprintf(out_, "  %s\n", line.c_str());
  if (above_the_block) redraw(now);
  std::fflush(out_);
}

int ProgressDisplay::joints_done() const { return static_cast<int>(std::count(done_.begin(), done_.end(), true)); }

void ProgressDisplay::redraw(Clock::time_point now) {
  if (drawn_ > 0) std::fprintf(out_, "\x1b[%dA", drawn_);
  const double elapsed = std::chrono::duration<double>(now - block_start_).count();
  std::fprintf(out_, "\x1b[2K  %s: %s\n", estimator_.c_str(), summary(joints_done(), joints_, elapsed).c_str());
  for (int j = 0; j < joints_; ++j)
    std::fprintf(out_, "\x1b[2K    joint %d: %s\n", j + 1, lines_[static_cast<size_t>(j)].c_str());
  drawn_ = joints_ + 1;
  last_draw_ = now;
  std::fflush(out_);
}

void ProgressDisplay::observe(const ProgressEvent& e, Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mu_);
  const bool sampled_out = !e.finished && e.iteration != 1 && e.iteration % kPlainIterationStep != 0;
  if (e.joint < 0 || e.joint >= joints_) {  // a note, a whole fit's iteration (lip, a network) or its end
    if (e.finished) end_block();
    if (!sampled_out) print_plain(describe(e), now);  // a note (iteration 0) is never sampled out
    return;
  }
  if (e.estimator != estimator_) start_block(e.estimator, now);
  const auto j = static_cast<size_t>(e.joint);
  ProgressEvent without_name = e;
  without_name.estimator.clear();
  without_name.joint = -1;
  lines_[j] = describe(without_name);
  if (e.finished) done_[j] = true;
  if (terminal_) {
    if (e.finished || drawn_ == 0 || now - last_draw_ >= kRedrawInterval) redraw(now);
    return;
  }
  if (sampled_out) return;
  std::string line = describe(e);
  if (e.finished) line += "; " + summary(joints_done(), joints_, std::chrono::duration<double>(now - block_start_).count());
  std::fprintf(out_, "  %s\n", line.c_str());
  std::fflush(out_);
}

}  // namespace gipdyn::cli
