// The minimisers on functions whose minima are known.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"
#include "gipdyn/optim/optimizer.hpp"

using namespace gipdyn;

namespace {

// sum_k (x_k - 3)^2: minimum 0 at x = 3.
bool shifted_quadratic(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
  const Eigen::VectorXd d = x.array() - 3.0;
  f = d.squaredNorm();
  g = 2.0 * d;
  return true;
}

bool rosenbrock(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
  const double a = 1.0 - x(0), b = x(1) - x(0) * x(0);
  f = a * a + 100.0 * b * b;
  g.resize(2);
  g << -2.0 * a - 400.0 * x(0) * b, 200.0 * b;
  return true;
}

}  // namespace

// Adam moves each coordinate by at most about one learning rate per step, so
// from 0 it needs several hundred steps to reach 3: nearly every one of them
// improves the objective, and the patience rule must not stop it after
// adam_patience steps.
TEST(Adam, KeepsGoingWhileItImprovesBeyondThePatience) {
  OptimizerOptions o;
  o.kind = OptimizerKind::Adam;
  o.adam_learning_rate = 0.01;
  o.adam_patience = 20;
  o.max_iterations = 2000;
  const OptimizerResult r = minimize(shifted_quadratic, Eigen::VectorXd::Zero(2), o);
  EXPECT_GT(r.evaluations, 10 * o.adam_patience) << r.message;
  EXPECT_LT(r.f, 1e-2) << r.message;
  EXPECT_NEAR(r.x(0), 3.0, 0.1);
}

TEST(Adam, StopsWhenNothingImprovesForPatienceSteps) {
  OptimizerOptions o;
  o.kind = OptimizerKind::Adam;
  o.adam_patience = 5;
  o.gradient_tolerance = 0.0;
  o.max_iterations = 1000;
  // Flat: every step has the same objective, so none is an improvement after the first.
  const Objective flat = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
    f = 1.0;
    g = Eigen::VectorXd::Constant(x.size(), 1e-3);
    return true;
  };
  const OptimizerResult r = minimize(flat, Eigen::VectorXd::Zero(2), o);
  EXPECT_EQ(r.status, OptimizerResult::Status::Converged);
  EXPECT_EQ(r.evaluations, 1 + o.adam_patience);
}

TEST(Lbfgs, ConvergesOnRosenbrockAndReportsTheGradientThere) {
  OptimizerOptions o;
  o.max_iterations = 500;
  o.f_relative_tolerance = 1e-14;
  const OptimizerResult r = minimize(rosenbrock, Eigen::Vector2d(-1.2, 1.0), o);
  EXPECT_EQ(r.status, OptimizerResult::Status::Converged) << r.message;
  EXPECT_NEAR(r.x(0), 1.0, 1e-4);
  EXPECT_NEAR(r.x(1), 1.0, 1e-4);
  EXPECT_LT(r.grad_norm, 1e-3);
  EXPECT_LT(r.evaluations, o.max_iterations);
}

// NLopt has no gradient test; ours stops L-BFGS at the first point whose
// projected gradient meets the tolerance, and the result says so.
TEST(Lbfgs, StopsAtTheGradientToleranceAndSaysSo) {
  OptimizerOptions o;
  o.f_relative_tolerance = 0.0;
  o.gradient_tolerance = 1e-2;
  const OptimizerResult loose = minimize(rosenbrock, Eigen::Vector2d(-1.2, 1.0), o);
  EXPECT_EQ(loose.status, OptimizerResult::Status::Converged) << loose.message;
  EXPECT_NE(loose.message.find("gradient"), std::string::npos) << loose.message;
  EXPECT_LE(loose.grad_norm, 1e-2);
  o.gradient_tolerance = 1e-9;
  const OptimizerResult tight = minimize(rosenbrock, Eigen::Vector2d(-1.2, 1.0), o);
  EXPECT_GT(tight.evaluations, loose.evaluations);
  EXPECT_LT(tight.grad_norm, loose.grad_norm);
}

TEST(Lbfgs, StaysInsideTheBoxAndProjectsTheGradientThere) {
  OptimizerOptions o;
  o.lower_bounds = Eigen::Vector2d(-10.0, -10.0);
  o.upper_bounds = Eigen::Vector2d(2.0, 10.0);  // the minimum x0 = 3 lies outside
  const OptimizerResult r = minimize(shifted_quadratic, Eigen::Vector2d(0.0, 0.0), o);
  EXPECT_TRUE(r.usable()) << r.message;
  EXPECT_NEAR(r.x(0), 2.0, 1e-8);
  EXPECT_NEAR(r.x(1), 3.0, 1e-5);
  EXPECT_LT(r.grad_norm, 1e-4);  // the outward gradient at the active bound does not count
}

// A quadratic whose values carry a deterministic roughness of 1e-3, as an
// ill-conditioned NLL's rounding does, while its gradient is exact. Near the
// minimum no line search can see a decrease below that roughness: the run is
// done to the objective's precision, and says so instead of "stalled".
TEST(Lbfgs, ALineSearchDefeatedByTheObjectivesRoundingIsConvergence) {
  const Objective rough = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
    const Eigen::VectorXd d = x.array() - 3.0;
    const double hash = std::sin(x.dot(Eigen::VectorXd::LinSpaced(x.size(), 12.9898, 78.233)) * 1e4) * 43758.5453;
    f = d.squaredNorm() + 1e-3 * (hash - std::floor(hash));
    g = 2.0 * d;
    return true;
  };
  OptimizerOptions o;
  o.gradient_tolerance = 1e-9;  // far below what the roughness lets any method verify
  o.f_relative_tolerance = 0.0;
  const OptimizerResult r = minimize(rough, Eigen::VectorXd::Constant(4, 0.0), o);
  EXPECT_EQ(r.status, OptimizerResult::Status::Converged) << r.message;
  EXPECT_NE(r.message.find("rounding"), std::string::npos) << r.message;
  EXPECT_LT((r.x.array() - 3.0).abs().maxCoeff(), 0.05);  // within sqrt(1e-3) of the minimum
}

// A gradient that points uphill: every line search fails at once, yet the
// objective is smooth and falls steeply the other way. That is a stall to
// report, not rounding.
TEST(Lbfgs, ALineSearchThatFailsOnASmoothObjectiveIsAStall) {
  const Objective uphill = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
    const Eigen::VectorXd d = x.array() - 3.0;
    f = d.squaredNorm();
    g = -2.0 * d;
    return true;
  };
  const OptimizerResult r = minimize(uphill, Eigen::VectorXd::Constant(2, 0.0), OptimizerOptions{});
  EXPECT_EQ(r.status, OptimizerResult::Status::Stalled) << r.message;
}

// The caller's gate sees every evaluation count and the best objective so
// far, and a closed gate ends the run there, for either minimiser, with the
// best point so far and a message that says who stopped it.
TEST(Minimize, AClosedGateEndsTheRunWithItsBestPoint) {
  for (OptimizerKind kind : {OptimizerKind::Lbfgs, OptimizerKind::Adam}) {
    SCOPED_TRACE(to_string(kind));
    OptimizerOptions o;
    o.kind = kind;
    o.max_iterations = 500;
    std::vector<int> asked;
    double best_seen = 0.0;
    const EvaluationGate gate = [&](int evaluations, double best) {
      asked.push_back(evaluations);
      best_seen = best;
      return evaluations < 7;
    };
    const OptimizerResult r = minimize(rosenbrock, Eigen::Vector2d(-1.2, 1.0), o, {}, gate);
    EXPECT_EQ(r.status, OptimizerResult::Status::MaxIterations);
    EXPECT_EQ(r.evaluations, 7);
    EXPECT_EQ(asked, (std::vector<int>{1, 2, 3, 4, 5, 6, 7}));
    EXPECT_EQ(r.f, best_seen);
    EXPECT_NE(r.message.find("stopped by the caller after 7 evaluations"), std::string::npos) << r.message;
    const OptimizerResult open = minimize(rosenbrock, Eigen::Vector2d(-1.2, 1.0), o, {},
                                          [](int, double) { return true; });
    EXPECT_GT(open.evaluations, 7);
  }
}

// Rosenbrock scaled by s: the same valley, s times as deep.
Objective scaled_rosenbrock(double s) {
  return [s](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
    const bool ok = rosenbrock(x, f, g);
    f *= s;
    g *= s;
    return ok;
  };
}

// The plateau rule stops a run, for either minimiser, at the first
// evaluation e > W at which the best objective after e is less than
// plateau_decrease below the best after e - W (W = plateau_evaluations), and
// calls it converged; it never stops a run that falls faster.
TEST(Minimize, APlateauEndsTheRunAtTheFirstWindowThatGainsTooLittle) {
  constexpr int kWindow = 20;
  constexpr double kDecrease = 0.1;
  for (OptimizerKind kind : {OptimizerKind::Lbfgs, OptimizerKind::Adam}) {
    // 1e-3: the start is 0.0242 above the minimum, less than the plateau's
    // decrease, so evaluation 21 ends the run. 10: the run falls by more than
    // that per window for a while, and may end by another rule.
    for (double scale : {1e-3, 10.0}) {
      SCOPED_TRACE(to_string(kind) + " at scale " + std::to_string(scale));
      OptimizerOptions o;
      o.kind = kind;
      o.max_iterations = 3000;
      o.gradient_tolerance = 0.0;
      o.f_relative_tolerance = 0.0;
      o.adam_learning_rate = 0.05;
      o.adam_patience = 3000;
      o.plateau_evaluations = kWindow;
      o.plateau_decrease = kDecrease;
      std::vector<double> best_after;  // the best objective after evaluations 1, 2, ...
      const ProgressCallback record = [&](const ProgressEvent& e) {
        ASSERT_EQ(e.iteration, static_cast<int>(best_after.size()) + 1);
        best_after.push_back(best_after.empty() ? e.objective : std::min(best_after.back(), e.objective));
      };
      const OptimizerResult r = minimize(scaled_rosenbrock(scale), Eigen::Vector2d(-1.2, 1.0), o, record);
      ASSERT_EQ(static_cast<int>(best_after.size()), r.evaluations);
      int first_plateau = 0;
      for (int e = kWindow + 1; e <= r.evaluations && first_plateau == 0; ++e)
        if (best_after[static_cast<size_t>(e - kWindow - 1)] - best_after[static_cast<size_t>(e - 1)] < kDecrease)
          first_plateau = e;
      const bool on_plateau = r.message.find("fell by less than 0.1 over the last 20 evaluations") != std::string::npos;
      // Ended by the rule exactly where it first applies, or by another rule before it ever did.
      EXPECT_EQ(r.evaluations, on_plateau ? first_plateau : r.evaluations) << r.message;
      EXPECT_EQ(first_plateau, on_plateau ? r.evaluations : 0) << r.message;
      EXPECT_EQ(r.status, OptimizerResult::Status::Converged) << r.message;
      if (scale < 1.0) {
        EXPECT_TRUE(on_plateau) << r.message;
        EXPECT_EQ(r.evaluations, kWindow + 1);
      } else {
        EXPECT_GT(r.evaluations, 2 * kWindow) << r.message;
      }
      EXPECT_EQ(r.f, best_after.back());
    }
  }
  OptimizerOptions bad;
  bad.plateau_evaluations = -1;
  EXPECT_THROW(bad.validate(), Error);
  bad.plateau_evaluations = kWindow;
  bad.plateau_decrease = std::nan("");
  EXPECT_THROW(bad.validate(), Error);
}

TEST(Minimize, ReportsFailureWhenNoPointCanBeEvaluated) {
  const Objective broken = [](const Eigen::VectorXd&, double&, Eigen::VectorXd&) { return false; };
  for (OptimizerKind kind : {OptimizerKind::Lbfgs, OptimizerKind::Adam}) {
    OptimizerOptions o;
    o.kind = kind;
    const OptimizerResult r = minimize(broken, Eigen::VectorXd::Zero(3), o);
    EXPECT_EQ(r.status, OptimizerResult::Status::Failed);
    EXPECT_FALSE(r.usable());
    EXPECT_NE(r.message.find("not positive definite"), std::string::npos);
  }
}

TEST(BestOfStarts, KeepsTheLowestUsableRunAndEveryObjective) {
  gipdyn::BestOfStarts starts;
  gipdyn::OptimizerResult failed;
  failed.message = "not positive definite";
  starts.add(failed);
  EXPECT_FALSE(starts.found());
  EXPECT_EQ(starts.kept.message, "not positive definite");
  gipdyn::OptimizerResult a, b;
  a.status = b.status = gipdyn::OptimizerResult::Status::Converged;
  a.f = 3.0;
  b.f = -1.0;
  b.x = Eigen::VectorXd::Ones(2);
  starts.add(a);
  starts.add(b);
  starts.add(a);
  ASSERT_TRUE(starts.found());
  EXPECT_EQ(starts.kept.f, -1.0);
  EXPECT_EQ(starts.kept.x, b.x);
  ASSERT_EQ(starts.objectives.size(), 4u);
  EXPECT_TRUE(std::isnan(starts.objectives[0]));
  EXPECT_EQ(starts.objectives[3], 3.0);
}

// Screening's continued starts: start 0 trails at the budget (a long, shallow
// valley whose floor is lowest), start 1 leads there (a steep, shallower
// basin). Only the leader goes on by default, and the kept objective is the
// leader's; with continued_starts = 1 start 0 goes on too and its lower floor is kept.
TEST(SearchHyperparameters, AContinuedStartGoesOnBesideTheLeader) {
  const std::vector<Eigen::VectorXd> starts{Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 0.5)};
  const StartObjective objective_for = [](int start) -> Objective {
    if (start == 0)
      return [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {  // floor -2 at x = 10
        const double d = x(0) - 10.0;
        f = 0.01 * d * d - 2.0;
        g = Eigen::VectorXd::Constant(1, 0.02 * d);
        return true;
      };
    return [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {  // floor -1.5 at x = 0
      f = x(0) * x(0) - 1.5;
      g = Eigen::VectorXd::Constant(1, 2.0 * x(0));
      return true;
    };
  };
  SearchOptions options;
  options.screening_evaluations = 1;  // at the budget: start 0 at -1, start 1 at -1.25
  options.threads = 2;
  const SearchResult leader_only = search_hyperparameters(starts, objective_for, options);
  EXPECT_EQ(leader_only.screening_evaluations, 1);
  EXPECT_NEAR(leader_only.best.kept.f, -1.5, 1e-8);
  EXPECT_NEAR(leader_only.best.objectives[0], -1.0, 1e-12) << "start 0 stops at the budget";

  options.continued_starts = 1;
  const SearchResult continued = search_hyperparameters(starts, objective_for, options);
  EXPECT_EQ(continued.screening_evaluations, 0) << "no start was stopped";
  EXPECT_NEAR(continued.best.kept.f, -2.0, 1e-8);
  EXPECT_NEAR(continued.best.objectives[1], -1.5, 1e-8);

  options.continued_starts = -1;
  EXPECT_THROW(search_hyperparameters(starts, objective_for, options), Error);
}
