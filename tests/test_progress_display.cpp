// train's progress display: plain lines with the estimate off a terminal, one line per joint in place on one.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "progress_display.hpp"

using gipdyn::ProgressEvent;
using gipdyn::cli::ProgressDisplay;

namespace {

std::string contents(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string text;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  return text;
}

ProgressEvent event(int joint, int iteration, bool finished = false) {
  ProgressEvent e;
  e.estimator = "gip";
  e.joint = joint;
  e.iteration = iteration;
  e.objective = -10.0 * iteration;
  e.seconds = 0.1 * iteration;
  e.finished = finished;
  if (finished) e.message = "converged";
  return e;
}

}  // namespace

TEST(ProgressDisplay, TheEstimateIsTheJointsLeftTimesTheTimePerFinishedJoint) {
  EXPECT_EQ(ProgressDisplay::summary(0, 4, 12.0), "0 of 4 joints done, 12 s elapsed");
  EXPECT_EQ(ProgressDisplay::summary(1, 4, 20.0), "1 of 4 joints done, 20 s elapsed, about 60 s left");
  EXPECT_EQ(ProgressDisplay::summary(2, 6, 600.0), "2 of 6 joints done, 10.0 min elapsed, about 20.0 min left");
  EXPECT_EQ(ProgressDisplay::summary(3, 3, 7.0), "3 of 3 joints done, 7 s elapsed");
}

TEST(ProgressDisplay, OffATerminalEveryJointsEndSaysWhatIsLeftInPlainLines) {
  std::FILE* f = std::tmpfile();
  ProgressDisplay display(f, 2, false);
  const auto t0 = ProgressDisplay::Clock::now();
  display.observe(event(0, 1), t0);
  display.observe(event(0, 5), t0);  // sampled out
  display.observe(event(0, 10), t0);
  display.observe(event(0, 12, true), t0 + std::chrono::seconds(30));
  display.observe(event(1, 20, true), t0 + std::chrono::seconds(40));
  const std::string text = contents(f);
  EXPECT_NE(text.find("gip joint 1 iteration 1: objective -10"), std::string::npos) << text;
  EXPECT_EQ(text.find("iteration 5:"), std::string::npos) << text;
  EXPECT_NE(text.find("gip joint 1 done after 12 iterations (1.2 s): objective -120, converged; 1 of 2 joints done, "
                      "30 s elapsed, about 30 s left"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("gip joint 2 done after 20 iterations (2.0 s): objective -200, converged; 2 of 2 joints done, "
                      "40 s elapsed\n"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("\x1b["), std::string::npos);  // no terminal codes in a log file
  std::fclose(f);
}

TEST(ProgressDisplay, OnATerminalEachJointHasOneLineRewrittenInPlaceUnderTheSummary) {
  std::FILE* f = std::tmpfile();
  ProgressDisplay display(f, 2, true);
  const auto t0 = ProgressDisplay::Clock::now();
  display.observe(event(0, 1), t0);
  display.observe(event(1, 1), t0 + std::chrono::seconds(1));
  display.note("lip fit converged (3.0 s)");
  display.observe(event(0, 30, true), t0 + std::chrono::seconds(10));
  const std::string text = contents(f);
  // The block is three lines (summary, joint 1, joint 2); each redraw moves up over it first.
  EXPECT_NE(text.find("\x1b[3A"), std::string::npos) << text;
  EXPECT_NE(text.find("  lip fit converged (3.0 s)\n"), std::string::npos);
  // The last drawing: joint 1 done, joint 2 at its first iteration, and the estimate.
  const std::string last = text.substr(text.rfind("gip: "));
  EXPECT_EQ(last.find("gip: 1 of 2 joints done, 10 s elapsed, about 10 s left\n"), 0u) << last;
  EXPECT_NE(last.find("joint 1: done after 30 iterations (3.0 s): objective -300, converged\n"), std::string::npos) << last;
  EXPECT_NE(last.find("joint 2: iteration 1: objective -10"), std::string::npos) << last;
  std::fclose(f);
}
