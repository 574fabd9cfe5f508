#include "gipdyn/optim/optimizer.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <nlopt.hpp>

#include "gipdyn/error.hpp"

namespace gipdyn {

OptimizerResult::Status parse_optimizer_status(const std::string& name) {
  for (auto s : {OptimizerResult::Status::Converged, OptimizerResult::Status::MaxIterations,
                 OptimizerResult::Status::Stalled, OptimizerResult::Status::Failed})
    if (to_string(s) == name) return s;
  throw Error("unknown optimizer status '" + name + "'");
}

OptimizerKind parse_optimizer(const std::string& name) {
  if (name == "lbfgs") return OptimizerKind::Lbfgs;
  if (name == "adam") return OptimizerKind::Adam;
  throw Error("OptimizerOptions::kind '" + name + "' is unknown; choose lbfgs or adam");
}

void BestOfStarts::add(const OptimizerResult& run) {
  objectives.push_back(run.usable() ? run.f : std::numeric_limits<double>::quiet_NaN());
  if (run.usable() && (!found_ || run.f < kept.f)) {
    kept = run;
    found_ = true;
  } else if (!found_) {
    kept.message = run.message;
  }
}

std::string to_string(OptimizerKind kind) { return kind == OptimizerKind::Lbfgs ? "lbfgs" : "adam"; }

std::string to_string(OptimizerResult::Status status) {
  switch (status) {
    case OptimizerResult::Status::Converged: return "converged";
    case OptimizerResult::Status::MaxIterations: return "max-iter";
    case OptimizerResult::Status::Stalled: return "stalled";
    case OptimizerResult::Status::Failed: return "failed";
  }
  return "failed";
}

void OptimizerOptions::validate() const {
  if (max_iterations < 1) throw Error("OptimizerOptions::max_iterations must be at least 1");
  if (!(f_relative_tolerance >= 0.0)) throw Error("OptimizerOptions::f_relative_tolerance must be >= 0");
  if (!(gradient_tolerance >= 0.0)) throw Error("OptimizerOptions::gradient_tolerance must be >= 0");
  if (plateau_evaluations < 0) throw Error("OptimizerOptions::plateau_evaluations must be >= 0 (0: off)");
  if (!(plateau_decrease >= 0.0 && std::isfinite(plateau_decrease)))
    throw Error("OptimizerOptions::plateau_decrease must be finite and >= 0");
  if (lbfgs_memory < 1) throw Error("OptimizerOptions::lbfgs_memory must be at least 1");
  if (!(adam_learning_rate > 0.0)) throw Error("OptimizerOptions::adam_learning_rate must be > 0");
  if (!(adam_beta1 >= 0.0 && adam_beta1 < 1.0 && adam_beta2 >= 0.0 && adam_beta2 < 1.0))
    throw Error("OptimizerOptions::adam_beta1 and adam_beta2 must lie in [0, 1)");
  if (lower_bounds.size() != upper_bounds.size()) throw Error("OptimizerOptions::lower_bounds and upper_bounds must have the same size");
  if ((lower_bounds.array() > upper_bounds.array()).any()) throw Error("OptimizerOptions::lower_bounds exceeds upper_bounds");
}

namespace {

// Whether descent along -g(k) would leave the box at an active bound of x(k).
bool points_out_of_the_box(const Eigen::VectorXd& x, const Eigen::VectorXd& g, const OptimizerOptions& o,
                           Eigen::Index k) {
  if (o.lower_bounds.size() != x.size()) return false;
  return (x(k) <= o.lower_bounds(k) && g(k) > 0.0) || (x(k) >= o.upper_bounds(k) && g(k) < 0.0);
}

// Projected gradient: components at an active bound that point outwards are zero.
double projected_gradient_norm(const Eigen::VectorXd& x, const Eigen::VectorXd& g, const OptimizerOptions& o) {
  double norm = 0.0;
  for (Eigen::Index k = 0; k < g.size(); ++k)
    if (!points_out_of_the_box(x, g, o, k)) norm = std::max(norm, std::abs(g(k)));
  return norm;
}

// Tracks the best feasible point across evaluations, whatever the algorithm does.
struct Tracker {
  const Objective& objective;
  const ProgressCallback& progress;
  const OptimizerOptions& options;
  double best_f = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_x, best_g;
  double best_grad_norm = std::numeric_limits<double>::quiet_NaN();
  int evaluations = 0;
  int failures = 0;
  const EvaluationGate& gate;
  bool at_cap = false;  // L-BFGS asked for an evaluation beyond OptimizerOptions::max_iterations
  bool gradient_small = false;  // an evaluated point met OptimizerOptions::gradient_tolerance
  bool gate_closed = false;     // the caller's gate ended the run
  bool on_plateau = false;      // OptimizerOptions::plateau_decrease: the best objective stopped falling
  std::vector<double> best_history{};  // best_f after each evaluation, while the plateau rule is on

  // Whether another evaluation is allowed: below the cap and through the gate
  // (asked once per evaluation; once closed it stays closed).
  bool may_evaluate() {
    if (evaluations >= options.max_iterations || gate_closed) return false;
    if (gate && evaluations > 0 && !gate(evaluations, best_f)) gate_closed = true;
    return !gate_closed;
  }
  std::string stop_message() const {
    return gate_closed ? "stopped by the caller after " + std::to_string(evaluations) + " evaluations"
                       : "stopped at the evaluation limit (" + std::to_string(options.max_iterations) + ")";
  }

  // Failed evaluations count too: they are evaluations the plateau has cost.
  void note_best_for_plateau() {
    const int window = options.plateau_evaluations;
    if (window == 0) return;
    best_history.push_back(best_f);
    const size_t k = best_history.size();
    on_plateau = k > static_cast<size_t>(window) && std::isfinite(best_history[k - 1 - window]) &&
                 best_history[k - 1 - window] - best_f < options.plateau_decrease;
  }

  bool eval(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
    ++evaluations;
    const bool ok = objective(x, f, g) && std::isfinite(f) && g.allFinite();
    if (!ok) {
      ++failures;
      note_best_for_plateau();
      return false;
    }
    const double grad_norm = projected_gradient_norm(x, g, options);
    if (f < best_f) {
      best_f = f;
      best_x = x;
      best_g = g;
      best_grad_norm = grad_norm;
      gradient_small = grad_norm <= options.gradient_tolerance;
    }
    note_best_for_plateau();
    if (progress) {
      ProgressEvent e;
      e.iteration = evaluations;
      e.objective = f;
      e.grad_norm = grad_norm;
      progress(e);
    }
    return true;
  }
};

Eigen::VectorXd clamp(const Eigen::VectorXd& x, const OptimizerOptions& o) {
  if (o.lower_bounds.size() != x.size()) return x;
  return x.cwiseMax(o.lower_bounds).cwiseMin(o.upper_bounds);
}

// One NLopt L-BFGS run from x0 with at most max_eval evaluations.
nlopt::result lbfgs_once(Tracker& t, const Eigen::VectorXd& x0, const OptimizerOptions& o, int max_eval,
                         std::string& error) {
  const unsigned n = static_cast<unsigned>(x0.size());
  nlopt::opt opt(nlopt::LD_LBFGS, n);
  opt.set_min_objective(
      [](unsigned dim, const double* x, double* grad, void* data) -> double {
        auto* tr = static_cast<Tracker*>(data);
        // NLopt notices a forced stop only at its next check, and may ask for
        // more points before it: once on a plateau, none is evaluated.
        if (tr->on_plateau) throw nlopt::forced_stop();
        // NLopt may ask for one evaluation beyond its maxeval: the cap is ours to keep.
        if (!tr->may_evaluate()) {
          tr->at_cap = true;
          throw nlopt::forced_stop();
        }
        Eigen::VectorXd xv = Eigen::Map<const Eigen::VectorXd>(x, dim), g(dim);
        double f = 0.0;
        if (!tr->eval(xv, f, g)) throw nlopt::forced_stop();
        // NLopt has no gradient test: a first-order optimum is ours to recognise, and so is a plateau.
        if (tr->gradient_small || tr->on_plateau) throw nlopt::forced_stop();
        if (grad) Eigen::Map<Eigen::VectorXd>(grad, dim) = g;
        return f;
      },
      &t);
  if (o.lower_bounds.size() == x0.size()) {
    opt.set_lower_bounds(std::vector<double>(o.lower_bounds.data(), o.lower_bounds.data() + n));
    opt.set_upper_bounds(std::vector<double>(o.upper_bounds.data(), o.upper_bounds.data() + n));
  }
  opt.set_maxeval(max_eval);
  opt.set_ftol_rel(o.f_relative_tolerance);
  opt.set_vector_storage(static_cast<unsigned>(o.lbfgs_memory));
  std::vector<double> x(x0.data(), x0.data() + n);
  double f = 0.0;
  nlopt::result result = nlopt::FAILURE;
  try {
    result = opt.optimize(x, f);
  } catch (const nlopt::forced_stop&) {
    result = t.at_cap ? nlopt::MAXEVAL_REACHED : nlopt::FORCED_STOP;
    if (!t.at_cap) error = "the kernel matrix could not be factorised at a trial point";
  } catch (const nlopt::roundoff_limited&) {
    result = nlopt::ROUNDOFF_LIMITED;
  } catch (const std::exception& e) {
    // NLopt's generic failure: usually the line search broke down at a bound or
    // at rounding precision.
    error = e.what();
    result = nlopt::FAILURE;
  }
  // Our gradient test, our cap and the caller's gate stop NLopt from inside
  // the objective, and NLopt's L-BFGS reports such a stop as a failure rather
  // than as forced.
  if (t.gradient_small || t.on_plateau) return nlopt::SUCCESS;
  return t.at_cap ? nlopt::MAXEVAL_REACHED : result;
}

// Where L-BFGS can no longer improve on its best point, is the objective's
// rounding what hides the rest of the descent? An ill-conditioned NLL is
// deterministic but rough at the scale of its rounding (docs/results/training.md
// measures it), while its gradient
// stays smooth. Along the steepest descent d from the best point: the
// roughness is how far the objective strays from its first-order prediction
// at two steps too short to change it (1e-7 in the log-hyperparameters); the
// decrease left is the quadratic model's |g|^2 / (2 c), with the curvature c
// from the gradient a step of 1e-3 further. When the decrease left is below
// the roughness and the model's minimum is near, no line search can verify
// progress. Three evaluations, counted and tracked like any other.
struct RoundingCheck {
  bool limited = false;
  double roughness = 0.0, decrease_left = 0.0;
};

RoundingCheck check_rounding(Tracker& t, const OptimizerOptions& o) {
  RoundingCheck c;
  if (t.best_x.size() == 0 || t.best_g.size() != t.best_x.size()) return c;
  if (t.evaluations + 3 > o.max_iterations || !t.may_evaluate()) return c;  // the cap is a promise
  const Eigen::VectorXd x0 = t.best_x;
  Eigen::VectorXd d = -t.best_g;
  for (Eigen::Index k = 0; k < d.size(); ++k)
    if (points_out_of_the_box(x0, t.best_g, o, k)) d(k) = 0.0;
  const double slope = d.norm(), f0 = t.best_f;
  if (!(slope > 0.0)) return c;
  d /= slope;
  constexpr double kTiny = 1e-7, kStep = 1e-3;
  Eigen::VectorXd g(x0.size());
  double f = 0.0;
  for (double h : {kTiny, -kTiny}) {
    if (!t.eval(clamp(x0 + h * d, o), f, g)) return c;
    c.roughness = std::max(c.roughness, std::abs(f - (f0 - h * slope)));
  }
  if (!t.eval(clamp(x0 + kStep * d, o), f, g)) return c;
  const double curvature = (g.dot(d) + slope) / kStep;
  if (!(curvature > 0.0)) return c;
  c.decrease_left = slope * slope / (2.0 * curvature);
  c.limited = c.decrease_left < c.roughness && slope / curvature < 10.0 * kStep;
  return c;
}

std::string format_g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2g", v);
  return buf;
}

// Where L-BFGS has stopped improving: converged to the objective's rounding
// precision if the check says so, else stalled. Only the verdict changes; the
// path of the optimisation is the same either way.
OptimizerResult stalled_or_rounding_limited(Tracker& t, const OptimizerOptions& o, const std::string& stall) {
  OptimizerResult r;
  const RoundingCheck rounding = check_rounding(t, o);
  if (rounding.limited) {
    r.status = OptimizerResult::Status::Converged;
    r.message = "converged to rounding precision (the line search broke down where the objective's roughness, " +
                format_g(rounding.roughness) + ", exceeds the decrease left along the gradient, " +
                format_g(rounding.decrease_left) + ")";
  } else {
    r.status = OptimizerResult::Status::Stalled;
    r.message = stall;
  }
  return r;
}

std::string plateau_message(const OptimizerOptions& o) {
  return "converged (the objective fell by less than " + format_g(o.plateau_decrease) + " over the last " +
         std::to_string(o.plateau_evaluations) + " evaluations)";
}

OptimizerResult run_lbfgs(Tracker& t, const Eigen::VectorXd& x0, const OptimizerOptions& o) {
  OptimizerResult r;
  // A line-search breakdown often recovers when L-BFGS restarts from the best
  // point with a fresh curvature memory; give it a few tries while it improves.
  Eigen::VectorXd start = clamp(x0, o);
  double previous_best = std::numeric_limits<double>::infinity();
  for (int launch = 0; launch < 4; ++launch) {
    std::string error;
    const int remaining = o.max_iterations - t.evaluations;
    if (remaining <= 0 || t.gate_closed) {
      r.status = OptimizerResult::Status::MaxIterations;
      r.message = t.stop_message();
      return r;
    }
    const nlopt::result res = lbfgs_once(t, start, o, remaining, error);
    if (res == nlopt::MAXEVAL_REACHED) {
      r.status = OptimizerResult::Status::MaxIterations;
      r.message = t.stop_message();
      return r;
    }
    if (res > 0 || res == nlopt::ROUNDOFF_LIMITED) {
      r.status = OptimizerResult::Status::Converged;
      r.message = t.gradient_small ? "converged (gradient below tolerance)"
                  : t.on_plateau       ? plateau_message(o)
                  : res == nlopt::ROUNDOFF_LIMITED ? "converged to rounding precision"
                                                   : "converged (relative NLL change below tolerance)";
      return r;
    }
    const bool improved = t.best_x.size() > 0 &&
                          t.best_f < previous_best - o.f_relative_tolerance * std::abs(previous_best);
    if (!improved || t.best_x.size() == 0) return stalled_or_rounding_limited(
        t, o, "L-BFGS stopped (" + error + ") without further progress; kept the best point");
    previous_best = t.best_f;
    start = t.best_x;
  }
  return stalled_or_rounding_limited(t, o, "L-BFGS line search kept breaking down; kept the best point");
}

OptimizerResult run_adam(Tracker& t, const Eigen::VectorXd& x0, const OptimizerOptions& o) {
  OptimizerResult r;
  Eigen::VectorXd x = clamp(x0, o), g(x.size()), m = Eigen::VectorXd::Zero(x.size()), v = m;
  double f = 0.0, last_best = std::numeric_limits<double>::infinity();
  int since_improvement = 0;
  for (int k = 1; k <= o.max_iterations; ++k) {
    if (!t.may_evaluate()) break;
    if (!t.eval(x, f, g)) {
      r.status = OptimizerResult::Status::Stalled;
      r.message = "Adam reached a point where the kernel matrix could not be factorised; kept the best point";
      return r;
    }
    if (projected_gradient_norm(x, g, o) <= o.gradient_tolerance) {
      r.status = OptimizerResult::Status::Converged;
      r.message = "converged (gradient below tolerance)";
      return r;
    }
    if (t.on_plateau) {
      r.status = OptimizerResult::Status::Converged;
      r.message = plateau_message(o);
      return r;
    }
    // The first step always counts: inf - tol * inf would be NaN and never compare true.
    if (!std::isfinite(last_best) || t.best_f < last_best - o.f_relative_tolerance * std::abs(last_best)) {
      last_best = t.best_f;
      since_improvement = 0;
    } else if (++since_improvement >= o.adam_patience) {
      r.status = OptimizerResult::Status::Converged;
      r.message = "converged (no relative improvement in " + std::to_string(o.adam_patience) + " steps)";
      return r;
    }
    m = o.adam_beta1 * m + (1.0 - o.adam_beta1) * g;
    v = o.adam_beta2 * v + (1.0 - o.adam_beta2) * g.cwiseAbs2();
    const double c1 = 1.0 - std::pow(o.adam_beta1, k), c2 = 1.0 - std::pow(o.adam_beta2, k);
    x -= (o.adam_learning_rate * (m / c1).array() / ((v / c2).array().sqrt() + 1e-8)).matrix();
    x = clamp(x, o);
  }
  r.status = OptimizerResult::Status::MaxIterations;
  r.message = t.gate_closed ? t.stop_message() : "stopped at the step limit (" + std::to_string(o.max_iterations) + ")";
  return r;
}

}  // namespace

OptimizerResult minimize(const Objective& objective, const Eigen::VectorXd& x0, const OptimizerOptions& options,
                         const ProgressCallback& progress, const EvaluationGate& gate) {
  options.validate();
  Tracker tracker{objective, progress, options, std::numeric_limits<double>::infinity(), Eigen::VectorXd(), Eigen::VectorXd(),
                  std::numeric_limits<double>::quiet_NaN(), 0, 0, gate};
  OptimizerResult r = options.kind == OptimizerKind::Lbfgs ? run_lbfgs(tracker, x0, options) : run_adam(tracker, x0, options);
  r.evaluations = tracker.evaluations;
  if (tracker.best_x.size() == 0) {
    r.status = OptimizerResult::Status::Failed;
    r.message = "no hyperparameters could be evaluated: the kernel matrix is not positive definite even at the start";
    r.x = x0;
    r.f = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  r.x = tracker.best_x;
  r.f = tracker.best_f;
  r.grad_norm = tracker.best_grad_norm;
  return r;
}

}  // namespace gipdyn
