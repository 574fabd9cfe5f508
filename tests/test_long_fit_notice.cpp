// The command line's early warning that an exact fit will take long
// (apps/cli/long_fit_notice.hpp), with the clock given by the test.
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "long_fit_notice.hpp"

namespace {

using gipdyn::ProgressEvent;
using gipdyn::cli::LongFitNotice;
using Clock = LongFitNotice::Clock;

ProgressEvent evaluation(int joint, long rows, int iteration) {
  ProgressEvent e;
  e.joint = joint;
  e.rows = rows;
  e.iteration = iteration;
  return e;
}

// The note after a joint's first two evaluations, `seconds` apart.
std::string note_after(LongFitNotice& notice, int joint, long rows, double seconds) {
  const Clock::time_point t0{};
  notice.observe(evaluation(joint, rows, 1), t0);
  return notice.observe(evaluation(joint, rows, 2),
                        t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds)));
}

TEST(LongFitNotice, SpeaksOnceWhenAFitWillTakeTenMinutesOrMore) {
  LongFitNotice notice(4, 4);  // every joint at once: one wave
  EXPECT_EQ(note_after(notice, 0, 2000, 0.2), "");
  const std::string note = note_after(notice, 1, 10000, 13.6);
  EXPECT_NE(note.find("13.6 s per NLL evaluation on 10000 rows"), std::string::npos) << note;
  EXPECT_NE(note.find("18m08s to 1h08m"), std::string::npos) << note;  // 80 and 300 evaluations
  EXPECT_NE(note.find("--hyperparameter-rows"), std::string::npos) << note;
  EXPECT_NE(note.find("--inducing"), std::string::npos) << note;
  EXPECT_EQ(note_after(notice, 2, 10000, 20.0), "") << "said twice";
}

TEST(LongFitNotice, CountsTheWavesOfJointsThatCannotTrainAtOnce) {
  // 4 s an evaluation: 80 of them take 5m20s in one wave, 10m40s in two.
  LongFitNotice at_once(4, 4), two_at_a_time(4, 2);
  EXPECT_EQ(note_after(at_once, 0, 8000, 4.0), "");
  EXPECT_NE(note_after(two_at_a_time, 0, 8000, 4.0).find("10m40s"), std::string::npos);
}

TEST(LongFitNotice, IgnoresEventsThatAreNotAJointsFirstEvaluations) {
  LongFitNotice notice(2, 2);
  const Clock::time_point t0{}, later = t0 + std::chrono::hours(1);
  // A second evaluation without a first on the same joint and rows (a warm start's subsample, then all rows).
  notice.observe(evaluation(0, 500, 1), t0);
  EXPECT_EQ(notice.observe(evaluation(0, 10000, 2), later), "");
  // Whole-fit events and a joint's last event.
  ProgressEvent whole = evaluation(-1, 10000, 2), last = evaluation(1, 10000, 2);
  last.finished = true;
  notice.observe(evaluation(1, 10000, 1), t0);
  EXPECT_EQ(notice.observe(whole, later), "");
  EXPECT_EQ(notice.observe(last, later), "");
  // Later evaluations say nothing new either: the estimate comes from the first two.
  EXPECT_EQ(notice.observe(evaluation(1, 10000, 3), later), "");
  // The same joint's second evaluation itself does speak.
  EXPECT_NE(notice.observe(evaluation(1, 10000, 2), later), "");
}

TEST(LongFitNotice, SpeaksAfterAJointsFirstEvaluationWhenThatAloneTookLong) {
  // On 30000 rows one evaluation takes minutes: the note must not wait for a second.
  const auto first_evaluation = [](int joint, long rows, int restart, double seconds_since_start) {
    ProgressEvent e = evaluation(joint, rows, 1);
    e.restart = restart;
    e.seconds = seconds_since_start;
    return e;
  };
  LongFitNotice notice(4, 4);
  EXPECT_EQ(notice.observe(first_evaluation(0, 2000, 0, 0.5)), "");
  // Not a joint's first work: a later stage or restart, whose time since the joint's start includes the earlier ones.
  EXPECT_EQ(notice.observe(first_evaluation(0, 10000, 0, 3600.0)), "");
  EXPECT_EQ(notice.observe(first_evaluation(1, 10000, 1, 3600.0)), "");
  LongFitNotice fresh(4, 4);
  const std::string note = fresh.observe(first_evaluation(2, 10000, 0, 13.6));
  EXPECT_NE(note.find("13.6 s per NLL evaluation on 10000 rows"), std::string::npos) << note;
  EXPECT_NE(note.find("18m08s to 1h08m"), std::string::npos) << note;
  EXPECT_EQ(fresh.observe(first_evaluation(3, 10000, 0, 13.6)), "") << "said twice";
}

TEST(LongFitNotice, SaysBeforeAnExactFitOnManyRowsThatItWillTakeLong) {
  // On 30000 rows the first evaluation alone takes about ten minutes: say so before it.
  EXPECT_EQ(gipdyn::cli::long_exact_fit_note(gipdyn::kLongExactFitRows - 1), "");
  const std::string note = gipdyn::cli::long_exact_fit_note(30000);
  EXPECT_NE(note.find("30000 x 30000 matrix"), std::string::npos) << note;
  EXPECT_NE(note.find("--hyperparameter-rows"), std::string::npos) << note;
  EXPECT_NE(note.find("--inducing"), std::string::npos) << note;
}

}  // namespace
