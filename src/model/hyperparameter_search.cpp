#include "gipdyn/model/hyperparameter_search.hpp"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

void SearchSettings::validate() const {
  optimizer.validate();
  if (!(gradient_tolerance_per_row >= 0.0)) throw Error("SearchSettings::gradient_tolerance_per_row must be >= 0");
  if (restarts && (*restarts < 0 || *restarts > 1000))
    throw Error("SearchSettings::restarts must be between 0 and 1000");
  if (restart_spread && !(*restart_spread >= 0.0 && std::isfinite(*restart_spread)))
    throw Error("SearchSettings::restart_spread must be finite and >= 0");
  if (start_screening_evaluations && *start_screening_evaluations < 0)
    throw Error("SearchSettings::start_screening_evaluations must be >= 0 (0: every start runs to convergence)");
  if (hyperparameter_rows < 0) throw Error("SearchSettings::hyperparameter_rows must be >= 0 (0: all rows)");
  if (hyperparameter_rows > 0 && hyperparameter_rows < static_cast<int>(kMinTrainingRows))
    throw Error("SearchSettings::hyperparameter_rows must be 0 or at least " + std::to_string(kMinTrainingRows));
  if (!(initial_noise_fraction > 0.0)) throw Error("SearchSettings::initial_noise_fraction must be > 0");
  if (!(min_noise_fraction > 0.0) || min_noise_fraction > initial_noise_fraction)
    throw Error("SearchSettings::min_noise_fraction must be > 0 and not above SearchSettings::initial_noise_fraction (" +
                std::to_string(initial_noise_fraction) + ")");
  if (threads < 0) throw Error("SearchSettings::threads must be >= 0");
}

std::vector<Eigen::VectorXd> restart_points(const Eigen::VectorXd& from, const SearchSettings& settings,
                                            std::uint64_t stream) {
  std::mt19937_64 rng(settings.seed * 1000003ULL + stream);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Eigen::VectorXd> points;
  const double spread = settings.restart_spread_or_default();
  for (int r = 0; r < settings.restart_count(); ++r) {
    Eigen::VectorXd point = from;
    for (Eigen::Index k = 0; k < point.size(); ++k) point(k) += spread * normal(rng);
    points.push_back(point);
  }
  return points;
}

void SearchOptions::validate() const {
  optimizer.validate();
  if (screening_evaluations < 0)
    throw Error("SearchOptions::screening_evaluations must be >= 0 (0: every start runs to convergence)");
  if (continued_starts < 0) throw Error("SearchOptions::continued_starts must be >= 0 (0: only the leader goes on)");
  if (threads < 1) throw Error("SearchOptions::threads must be >= 1");
  if (!(bytes_per_start >= 0.0)) throw Error("SearchOptions::bytes_per_start must be >= 0");
}

namespace {

// At most `slots` evaluations at once, for starts that are all in flight but
// must share the cores as SearchOptions::threads asks.
class ComputeSlots {
 public:
  explicit ComputeSlots(int slots) : free_(slots) {}
  // Holds a slot for its lifetime (none for a null ComputeSlots).
  class Hold {
   public:
    explicit Hold(ComputeSlots* slots) : slots_(slots) {
      if (slots_) slots_->acquire();
    }
    ~Hold() {
      if (slots_) slots_->release();
    }
    Hold(const Hold&) = delete;
    Hold& operator=(const Hold&) = delete;

   private:
    ComputeSlots* slots_;
  };
  void acquire() {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [&] { return free_ > 0; });
    --free_;
  }
  void release() {
    {
      const std::lock_guard<std::mutex> lock(mu_);
      ++free_;
    }
    cv_.notify_one();
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  int free_;
};

// SearchOptions::screening_evaluations: every start runs up to the budget,
// waits there for the others (or for their end, where they converged sooner),
// and then only the one with the lowest objective so far goes on (the first of
// equals), with the first `continued` starts (SearchOptions::continued_starts).
class StartScreening {
 public:
  StartScreening(int starts, int budget, int continued)
      : best_(static_cast<size_t>(starts), std::numeric_limits<double>::infinity()),
        arrived_(static_cast<size_t>(starts), false), stopped_(static_cast<size_t>(starts), false), budget_(budget),
        continued_(continued) {}

  // Start r's EvaluationGate.
  bool proceed(int r, int evaluations, double best) {
    if (evaluations < budget_) return true;
    std::unique_lock<std::mutex> lock(mu_);
    if (!arrived_[static_cast<size_t>(r)]) arrive(r, best);
    cv_.wait(lock, [&] { return arrivals_ == static_cast<int>(best_.size()); });
    const bool goes_on = r == leader_ || r < continued_;
    if (!goes_on) stopped_[static_cast<size_t>(r)] = true;
    return goes_on;
  }
  // Whether the gate stopped a start (else every start ended before the budget).
  bool stopped_any() {
    const std::lock_guard<std::mutex> lock(mu_);
    return std::find(stopped_.begin(), stopped_.end(), true) != stopped_.end();
  }
  // Start r ended (converged, failed or threw) before its gate closed.
  void finished(int r, double best) {
    const std::lock_guard<std::mutex> lock(mu_);
    if (!arrived_[static_cast<size_t>(r)]) arrive(r, best);
  }

 private:
  void arrive(int r, double best) {
    arrived_[static_cast<size_t>(r)] = true;
    if (std::isfinite(best)) best_[static_cast<size_t>(r)] = best;
    if (++arrivals_ == static_cast<int>(best_.size())) {
      leader_ = static_cast<int>(std::min_element(best_.begin(), best_.end()) - best_.begin());
      cv_.notify_all();
    }
  }

  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<double> best_;
  std::vector<bool> arrived_, stopped_;
  int budget_, continued_, arrivals_ = 0, leader_ = -1;
};

}  // namespace

SearchResult search_hyperparameters(const std::vector<Eigen::VectorXd>& starts, const StartObjective& objective_for,
                                    const SearchOptions& options, const StartProgress& progress_for) {
  options.validate();
  const int num_starts = static_cast<int>(starts.size());
  if (num_starts == 0) throw Error("search_hyperparameters: no start points");
  // Screening keeps every start in flight, each with its workspace and its
  // optimiser's memory, so it needs the memory for all of them.
  const bool screened = options.concurrent_objectives && options.screening_evaluations > 0 && num_starts > 1 &&
                        options.screening_evaluations < options.optimizer.max_iterations &&
                        worker_threads(num_starts, num_starts, options.bytes_per_start) == num_starts;
  const int compute_threads =
      options.concurrent_objectives ? worker_threads(options.threads, num_starts, options.bytes_per_start) : 1;
  StartScreening screening(num_starts, options.screening_evaluations, options.continued_starts);
  ComputeSlots slots(compute_threads);
  std::vector<OptimizerResult> results(static_cast<size_t>(num_starts));
  run_tasks(num_starts, screened ? num_starts : compute_threads, [&](int r) {
    struct Finish {  // every way out of the start, an exception's too, must release the others' wait
      StartScreening& screening;
      int r;
      double best = std::numeric_limits<double>::infinity();
      ~Finish() { screening.finished(r, best); }
    } finish{screening, r};
    const Objective inner = objective_for(r);
    Objective objective = inner;
    if (screened)
      objective = [&](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
        const ComputeSlots::Hold hold(&slots);
        return inner(x, f, g);
      };
    EvaluationGate gate;
    if (screened) gate = [&](int evaluations, double best) { return screening.proceed(r, evaluations, best); };
    OptimizerResult& result = results[static_cast<size_t>(r)];
    result = minimize(objective, starts[static_cast<size_t>(r)], options.optimizer,
                      progress_for ? progress_for(r) : ProgressCallback(), gate);
    if (result.usable()) finish.best = result.f;
  });
  SearchResult out;
  for (const OptimizerResult& run : results) {
    out.evaluations += run.evaluations;
    out.best.add(run);
  }
  if (screened && screening.stopped_any()) out.screening_evaluations = options.screening_evaluations;
  return out;
}

}  // namespace gipdyn
