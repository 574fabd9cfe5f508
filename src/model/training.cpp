#include "gipdyn/model/training.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

#include "gipdyn/error.hpp"
#include "gipdyn/gp/sparse_gp.hpp"
#include "gipdyn/gp/weight_space_nll.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"

namespace gipdyn {

const char* const kFewerRowsAdvice = "train on fewer rows (a constant-step subsample)";

std::string to_string(HyperparameterObjective o) {
  return o == HyperparameterObjective::Exact ? "exact" : "bound";
}

HyperparameterObjective parse_hyperparameter_objective(const std::string& s) {
  if (s == "exact") return HyperparameterObjective::Exact;
  if (s == "bound") return HyperparameterObjective::SparseBound;
  throw Error("SparseOptions::hyperparameter_objective: unknown objective '" + s + "' (bound or exact)");
}

void GpOptions::validate() const {
  prior.validate();
  if (!(noise_std_floor.array() >= 0.0).all() || !noise_std_floor.allFinite())
    throw Error("GpOptions::noise_std_floor must hold finite values >= 0 (the noise's standard deviation per joint)");
  if (warm_start_rows < 0) throw Error("GpOptions::warm_start_rows must be >= 0 (0: no warm start)");
  if (warm_start_rows > 0 && warm_start_rows < static_cast<int>(kMinTrainingRows))
    throw Error("GpOptions::warm_start_rows must be 0 or at least " + std::to_string(kMinTrainingRows));
}

void SparseOptions::validate() const {
  if (inducing_points < 0) throw Error("SparseOptions::inducing_points must be >= 0 (0: exact GP)");
}

void TrainOptions::validate() const {
  require_known_kernel(kernel);
  if (kernel_needs_robot(kernel) && !robot_prior.robot)
    throw Error("kernel '" + kernel + "' is model-based and needs the nominal robot (TrainOptions::robot_prior)");
  search.validate();
  gp.validate();
  sparse.validate();
  const bool sparse_gp = sparse.inducing_points > 0;
  if (sparse_gp && sparse.hyperparameter_objective == HyperparameterObjective::Exact && search.hyperparameter_rows == 0)
    throw Error("SparseOptions::hyperparameter_objective exact with inducing points needs SearchSettings::hyperparameter_rows "
                "(the exact NLL of every row is what the sparse GP avoids): set it, e.g. to 1000");
  if (sparse_gp && gp.mean != MeanKind::Zero)
    throw Error("GpOptions::mean must be zero with inducing points (SparseOptions::inducing_points)");
  if (nll_backend) {
    if (sparse_gp)
      throw Error("TrainOptions::nll_backend computes the exact GP: set SparseOptions::inducing_points to 0, or leave "
                  "TrainOptions::nll_backend unset for a sparse GP");
    if (gp.mean != MeanKind::Zero)
      throw Error("TrainOptions::nll_backend needs GpOptions::mean zero (a profiled mean is not distributed)");
    if (gp.keep_factor)
      throw Error("GpOptions::keep_factor must be off with TrainOptions::nll_backend: the factor is spread over "
                  "its processes (a loaded model recomputes it for variances)");
  }
}

namespace {

struct JointOutcome {
  JointReport report;
  GpRegressor gp;
  MeanFunction mean;
  bool ok = false;
};

// A constant-step subsample of `count` rows of (X, Z, y).
struct RowSubset {
  Eigen::MatrixXd X, Z;
  Eigen::VectorXd y;
  RowSubset() = default;
  RowSubset(const Eigen::MatrixXd& X_all, const Eigen::MatrixXd& Z_all, const Eigen::VectorXd& y_all,
            Eigen::Index count) {
    const std::vector<Eigen::Index> rows = constant_step_indices(X_all.rows(), count);
    X = X_all(rows, Eigen::all);
    Z = Z_all(rows, Eigen::all);
    y = y_all(rows);
  }
};

// One joint's training: its search space from the data, the search over its
// hyperparameters (hyperparameter_search.hpp), and the final fit on every row.
class JointTraining {
 public:
  // Zm: the inducing rows' features of a sparse GP, or null for the exact GP.
  // noise_variance_floor: GpOptions::noise_std_floor of this joint, squared, in the scaled output's units.
  JointTraining(int j, const FeatureMap& features, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Z,
                const Eigen::MatrixXd* Zm, const Eigen::VectorXd& y, const TrainOptions& o,
                double noise_variance_floor, const ProgressCallback& progress)
      : j_(j), X_(X), Z_(Z), Zm_(Zm), y_(y), o_(o), progress_(progress), t0_(Clock::now()),
        target_(std::max(y.squaredNorm() / static_cast<double>(y.size()), 1e-12)),
        kernel_(make_kernel(o.kernel, features, j, o.robot_prior)),
        // The mean's coefficients are profiled out of the likelihood, not optimised.
        mean_(o.gp.mean, static_cast<int>(X.cols())),
        exact_objective_(o.sparse.hyperparameter_objective == HyperparameterObjective::Exact && o.search.hyperparameter_rows > 0 &&
                         X.rows() > o.search.hyperparameter_rows) {
    out_.report.joint = j;
    kernel_->initialize(Z, target_);
    P_ = kernel_->num_params();
    x0_.resize(P_ + 1);
    x0_.head(P_) = kernel_->log_params();
    x0_(P_) = std::log(o.search.initial_noise_fraction * target_);
    if (!o.gp.initial_log_params.empty()) x0_ = o.gp.initial_log_params[static_cast<size_t>(j)];  // sizes checked by train_model
    opt_ = o.search.optimizer;
    // Box bounds keep exp() finite and the noise above its floor.
    opt_.lower_bounds = Eigen::VectorXd::Constant(P_ + 1, -30.0);
    opt_.upper_bounds = Eigen::VectorXd::Constant(P_ + 1, 30.0);
    // A known noise floor above the whole variance would leave no room for the kernel: it stops at the variance.
    opt_.lower_bounds(P_) = std::log(std::max(o.search.min_noise_fraction * target_, std::min(noise_variance_floor, target_)));
    opt_.upper_bounds(P_) = std::log(10.0 * target_);
    kernel_->restrict_log_params(Z, opt_.lower_bounds.head(P_), opt_.upper_bounds.head(P_));
    x0_ = x0_.cwiseMax(opt_.lower_bounds).cwiseMin(opt_.upper_bounds);
  }

  JointOutcome run() {
    const Eigen::VectorXd best_x = search();
    if (best_x.size() == 0) {
      out_.report.message = "joint " + std::to_string(j_ + 1) + ": " + out_.report.message;
    } else {
      condition(best_x);
    }
    finish();
    return std::move(out_);
  }

 private:
  using Clock = std::chrono::steady_clock;

  double seconds() const { return std::chrono::duration<double>(Clock::now() - t0_).count(); }

  // The data-driven start, then the restarts perturbed from it (SearchSettings::restarts).
  std::vector<Eigen::VectorXd> start_points() const {
    std::vector<Eigen::VectorXd> starts{x0_};
    for (Eigen::VectorXd& start : restart_points(x0_, o_.search, static_cast<std::uint64_t>(j_)))
      starts.push_back(std::move(start));
    return starts;
  }

  // Start r's objective on the rows (Xr, Zr, yr), with its own kernel and
  // workspace: starts may run side by side (screening).
  Objective objective_on(const Eigen::MatrixXd& Xr, const Eigen::MatrixXd& Zr, const Eigen::VectorXd& yr, bool sparse,
                         bool distributed) const {
    struct State {
      std::unique_ptr<Kernel> trial;
      // The exact NLL on these rows: the options' backend on all rows, or this process's.
      std::shared_ptr<NllBackend> exact;
      SparseGpWorkspace sparse_ws;
      // The exact NLL of a finite feature expansion (PP) in weight space: the
      // same value and gradient without the O(N^3) factorisation.
      std::optional<WeightSpaceNll> weight_space;
    };
    auto state = std::make_shared<State>();
    state->trial = kernel_->clone();
    state->exact = distributed ? o_.nll_backend : std::make_shared<InProcessNll>(mean_, Xr);
    Eigen::MatrixXd Phi;
    if (!sparse && !distributed && mean_.kind() == MeanKind::Zero && kernel_->weight_space_features(Zr, Phi))
      state->weight_space.emplace(std::move(Phi), yr);
    return [this, &Xr, &Zr, &yr, state, sparse, distributed](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
      const int P = P_;
      Kernel& trial = *state->trial;
      trial.set_log_params(x.head(P));
      // The sparse bound on all rows unless asked for the exact NLL; a
      // warm-start subsample is small: the exact NLL there, in this process.
      NllEvaluation e = state->weight_space ? state->weight_space->evaluate(x.head(P), x(P))
                        : sparse ? evaluate_vfe(trial, x(P), Zr, yr, *Zm_, true, state->sparse_ws, o_.search.jitter)
                                 : state->exact->evaluate(trial, x(P), Zr, yr, true, nullptr, o_.search.jitter);
      if (!e.ok()) return false;
      f = e.nll;
      g = e.gradient;
      if (o_.gp.prior.enabled) f += prior_penalty(x, x0_, o_.gp.prior.width, &g);  // MAP
      return true;
    };
  }

  ProgressCallback progress_for(int restart, long rows) const {
    if (!progress_) return {};
    return [this, restart, rows](const ProgressEvent& optimizer_event) {
      ProgressEvent e = optimizer_event;
      e.estimator = o_.kernel;
      e.joint = j_;
      e.restart = restart;
      e.rows = rows;
      e.seconds = seconds();
      progress_(e);
    };
  }

  // The search from `from` on the rows (Xr, Zr, yr). all_rows: they are the
  // hyperparameter rows, not the warm-start subsample.
  SearchResult search_on(const Eigen::MatrixXd& Xr, const Eigen::MatrixXd& Zr, const Eigen::VectorXd& yr,
                         bool all_rows, const std::vector<Eigen::VectorXd>& from) const {
    const bool sparse = Zm_ && all_rows && !exact_objective_, distributed = o_.nll_backend && all_rows;
    SearchOptions search;
    search.optimizer = opt_;
    search.optimizer.gradient_tolerance = o_.search.gradient_tolerance_per_row * static_cast<double>(yr.size());
    search.screening_evaluations = o_.search.start_screening_or_default();
    search.continued_starts = 1;  // the data-driven (or taught) start: restarts only add to it
    search.threads = 1;  // the joints are the parallel work
    const double side = static_cast<double>(sparse ? Zm_->rows() : yr.size());
    search.bytes_per_start = (sparse ? 10.0 : 2.0) * 8.0 * side * side;  // as training_memory's per joint
    search.concurrent_objectives = !distributed;
    return search_hyperparameters(
        from, [&](int) { return objective_on(Xr, Zr, yr, sparse, distributed); }, search,
        [&](int restart) { return progress_for(restart, static_cast<long>(yr.size())); });
  }

  // The best hyperparameters [kernel log-params, log noise], or empty where no
  // start could be evaluated; fills the report's search fields.
  Eigen::VectorXd search() {
    // The rows the hyperparameters are learned on: all, or a constant-step subsample.
    const bool subsampled = o_.search.hyperparameter_rows > 0 && X_.rows() > o_.search.hyperparameter_rows;
    RowSubset h;
    if (subsampled) h = RowSubset(X_, Z_, y_, o_.search.hyperparameter_rows);
    const Eigen::MatrixXd& Xo = subsampled ? h.X : X_;
    const Eigen::MatrixXd& Zo = subsampled ? h.Z : Z_;
    const Eigen::VectorXd& yo = subsampled ? h.y : y_;
    if (subsampled) out_.report.hyperparameter_rows = static_cast<long>(yo.size());

    // Every start on the subsample when the data are large: the subsample's
    // optimum is a start close to the full data's, and there restarts are cheap.
    const bool warm = o_.gp.warm_start_rows > 0 && Xo.rows() >= 2 * static_cast<Eigen::Index>(o_.gp.warm_start_rows);
    SearchResult found;
    if (warm) {
      const RowSubset w(Xo, Zo, yo, o_.gp.warm_start_rows);
      found = search_on(w.X, w.Z, w.y, false, start_points());
      out_.report.warm_start_evaluations = found.evaluations;
    } else {
      found = search_on(Xo, Zo, yo, true, start_points());
      out_.report.evaluations = found.evaluations;
    }
    out_.report.screening_evaluations = found.screening_evaluations;
    out_.report.restart_nlls = found.best.objectives;
    OptimizerResult kept = found.best.kept;
    Eigen::VectorXd best_x = found.best.found() ? kept.x : Eigen::VectorXd();
    if (warm && best_x.size() > 0) {
      const SearchResult full = search_on(Xo, Zo, yo, true, {best_x});
      out_.report.evaluations += full.evaluations;
      kept = full.best.kept;
      best_x = full.best.found() ? kept.x : Eigen::VectorXd();
    }
    out_.report.status = kept.status;
    out_.report.message = kept.message;
    out_.report.grad_norm = kept.grad_norm;
    return best_x;
  }

  // The GP conditioned on every row at best_x (the mean's coefficients first).
  void condition(const Eigen::VectorXd& best_x) {
    const int P = P_;
    kernel_->set_log_params(best_x.head(P));
    GpWorkspace ws;
    SparseGpWorkspace sparse_ws;
    if (mean_.kind() != MeanKind::Zero) {  // the coefficients that go with the chosen hyperparameters
      Eigen::VectorXd beta;
      const NllEvaluation at_best =
          evaluate_profiled_nll(*kernel_, best_x(P), mean_, X_, Z_, y_, false, ws, &beta, o_.search.jitter);
      if (!at_best.ok()) {
        out_.report.status = OptimizerResult::Status::Failed;
        out_.report.message = "joint " + std::to_string(j_ + 1) + ": final fit failed: " + at_best.message;
        return;
      }
      mean_.set_params(beta);
    }
    out_.mean = mean_;
    out_.gp = GpRegressor(std::move(kernel_), best_x(P));
    CholeskyResult fit;
    if (Zm_) {
      SparsePosterior post = fit_sparse(out_.gp.kernel(), best_x(P), Z_, y_, *Zm_, sparse_ws, o_.search.jitter);
      fit = post.status;
      if (fit.ok())
        out_.gp.set_sparse_state(post.alpha, post.jitter, post.objective, std::move(post.inducing_factor),
                                 std::move(post.posterior_factor));
    } else if (o_.nll_backend) {  // the mean is zero there
      Eigen::VectorXd alpha;
      const NllEvaluation e = o_.nll_backend->evaluate(out_.gp.kernel(), best_x(P), Z_, y_, false, &alpha, o_.search.jitter);
      fit = fit_result(e);
      if (e.ok()) out_.gp.set_state(alpha, e.jitter, e.nll);
    } else {
      fit = out_.gp.fit(Z_, y_ - mean_.evaluate(X_), o_.gp.keep_factor, ws, o_.search.jitter);
    }
    if (!fit.ok()) {
      out_.report.status = OptimizerResult::Status::Failed;
      out_.report.message = "joint " + std::to_string(j_ + 1) + ": final fit failed: " + fit.message;
      return;
    }
    out_.ok = true;
    out_.report.nll = out_.gp.nll();
    out_.report.noise_variance = std::exp(best_x(P));
    out_.report.noise_share = out_.report.noise_variance / target_;
    out_.report.jitter = fit.jitter;
  }

  // The joint's last event, whatever the outcome.
  void finish() {
    out_.report.seconds = seconds();
    if (!progress_) return;
    ProgressEvent e;
    e.estimator = o_.kernel;
    e.joint = j_;
    e.iteration = out_.report.evaluations;
    e.objective = out_.ok ? out_.report.nll : std::numeric_limits<double>::quiet_NaN();
    e.seconds = out_.report.seconds;
    e.finished = true;
    e.message = out_.ok ? to_string(out_.report.status) : out_.report.message;
    progress_(e);
  }

  const int j_;
  const Eigen::MatrixXd &X_, &Z_;
  const Eigen::MatrixXd* Zm_;
  const Eigen::VectorXd& y_;
  const TrainOptions& o_;
  const ProgressCallback& progress_;
  const Clock::time_point t0_;
  const double target_;
  std::unique_ptr<Kernel> kernel_;
  MeanFunction mean_;
  const bool exact_objective_;
  int P_ = 0;
  Eigen::VectorXd x0_;
  OptimizerOptions opt_;
  JointOutcome out_;
};

// Every joint in flight holds two N x N matrices (the kernel, reused for its
// inverse, and the gradient's scratch); kept factors add one per joint. A
// sparse joint holds about ten M x M matrices and three row blocks, and keeps
// two factors. Train fewer joints at once when memory is short, refuse when
// even one cannot fit.
struct TrainingMemory {
  double per_joint = 0.0, kept = 0.0;
};

TrainingMemory training_memory(const TrainOptions& options, Eigen::Index rows, int joints) {
  const bool sparse = options.sparse.inducing_points > 0;
  const double side = static_cast<double>(sparse ? std::min<Eigen::Index>(options.sparse.inducing_points, rows) : rows);
  const double square = 8.0 * side * side;
  TrainingMemory m;
  m.per_joint = sparse ? 10.0 * square + 8.0 * 3.0 * 1024.0 * side : 2.0 * square;
  m.kept = sparse ? 2.0 * joints * square : options.gp.keep_factor ? joints * square : 0.0;
  return m;
}

}  // namespace

int joints_trained_at_once(const TrainOptions& options, Eigen::Index rows, int joints) {
  // A backend's evaluations are collective: one joint at a time, in the same order everywhere.
  if (options.nll_backend) return 1;
  const TrainingMemory memory = training_memory(options, rows, joints);
  return worker_threads(sharing_threads(options.search.threads, joints), joints, memory.per_joint, memory.kept);
}

TrainResult train_model(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                        const TrainOptions& options, const ProgressCallback& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  options.validate();
  validate_training_data(X, Y, joints);
  // Checked here, not only in make_kernel: the kernels are built in worker threads.
  if (kernel_needs_robot(options.kernel)) require_matching_robot(options.robot_prior, joints);
  use_single_threaded_blas();
  const int n = joints.size();
  const FeatureMap features(joints);
  const Eigen::MatrixXd Z = features.compute(X);
  if (options.gp.noise_std_floor.size() > 0 && options.gp.noise_std_floor.size() != n)
    throw Error("GpOptions::noise_std_floor needs one value per joint (" + std::to_string(n) + ") or none");
  if (!options.gp.initial_log_params.empty()) {  // checked here: the joints are trained in worker threads
    if (static_cast<int>(options.gp.initial_log_params.size()) != n)
      throw Error("GpOptions::initial_log_params needs one vector per joint (" + std::to_string(n) + ") or none");
    for (int j = 0; j < n; ++j) {
      const Eigen::Index P = make_kernel(options.kernel, features, j, options.robot_prior)->num_params();
      const Eigen::VectorXd& x = options.gp.initial_log_params[static_cast<size_t>(j)];
      if (x.size() != P + 1 || !x.allFinite())
        throw Error("GpOptions::initial_log_params of joint " + std::to_string(j + 1) + " needs " +
                    std::to_string(P + 1) + " finite values (kernel log-parameters, then the log noise variance)");
    }
  }
  const bool sparse = options.sparse.inducing_points > 0;
  if (sparse && options.sparse.inducing_points > X.rows())
    throw Error("SparseOptions::inducing_points (" + std::to_string(options.sparse.inducing_points) + ") exceeds the " +
                std::to_string(X.rows()) + " training rows; choose at most that many, or 0 for the exact GP");
  // Shared by every joint (the model keeps one set of inputs). The joints'
  // initial kernels differ only in scale, so the first one's choice serves all.
  std::vector<Eigen::Index> inducing_rows;
  if (sparse) {
    std::unique_ptr<Kernel> k = make_kernel(options.kernel, features, 0, options.robot_prior);
    k->initialize(Z, 1.0);
    inducing_rows = select_inducing_rows(*k, Z, options.sparse.inducing_points);
  }
  const Eigen::MatrixXd Zm = sparse ? Eigen::MatrixXd(Z(inducing_rows, Eigen::all)) : Eigen::MatrixXd();

  Eigen::VectorXd offset = Eigen::VectorXd::Zero(n), scale = Eigen::VectorXd::Ones(n);
  for (int j = 0; j < n; ++j) {
    const double mean = Y.col(j).mean();
    const double sd = std::sqrt((Y.col(j).array() - mean).square().mean());
    // A model-based kernel spans tau = Phi w exactly; a subtracted training mean is
    // not in that span (no constant regressor column on joints that gravity does
    // not load), so pp and sp are scaled but never centred.
    if (options.gp.scaling != OutputScaling::None && !kernel_needs_robot(options.kernel)) offset(j) = mean;
    if (options.gp.scaling == OutputScaling::Standardize && sd > 1e-12) scale(j) = sd;
  }

  std::vector<JointOutcome> outcomes(static_cast<size_t>(n));
  // A backend plans the memory of its own processes.
  if (options.nll_backend) {
    options.nll_backend->plan(Z, Y);
  } else {
    const TrainingMemory memory = training_memory(options, X.rows(), n);
    require_memory(
        memory.kept + memory.per_joint, "training on " + std::to_string(X.rows()) + " rows",
        std::string(kFewerRowsAdvice) +
            std::string(options.gp.keep_factor && !sparse ? " or without kept factors (GpOptions::keep_factor)" : "") +
            std::string(sparse ? " or with fewer inducing points"
                               : ", or a sparse GP (SparseOptions::inducing_points), or distributed over processes "
                                 "(TrainOptions::nll_backend)"));
  }
  const int threads = joints_trained_at_once(options, X.rows(), n);
  run_tasks(n, threads, [&](int j) {
    const Eigen::VectorXd y = ((Y.col(j).array() - offset(j)) / scale(j)).matrix();
    const double noise_floor = options.gp.noise_std_floor.size() > 0 ? options.gp.noise_std_floor(j) / scale(j) : 0.0;
    outcomes[static_cast<size_t>(j)] =
        JointTraining(j, features, X, Z, sparse ? &Zm : nullptr, y, options, noise_floor * noise_floor, progress).run();
  });

  TrainResult result;
  std::vector<GpRegressor> gps;
  std::vector<MeanFunction> means;
  for (auto& o : outcomes) {
    result.report.joints.push_back(o.report);
    if (!o.ok && result.report.message.empty()) result.report.message = o.report.message;
    gps.push_back(std::move(o.gp));
    means.push_back(o.mean);
  }
  result.report.status = result.report.message.empty() ? combine_joint_statuses(result.report.joints) : FitStatus::Failed;
  if (result.report.ok())
    result.model = InverseDynamicsModel(joints, options.kernel, sparse ? Eigen::MatrixXd(X(inducing_rows, Eigen::all)) : X,
                                        std::move(gps), options.gp.scaling, offset, scale, options.robot_prior,
                                        std::move(means), result.report.joints, X.rows());
  result.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

std::vector<Eigen::VectorXd> learned_log_params(const InverseDynamicsModel& model) {
  std::vector<Eigen::VectorXd> out;
  for (int j = 0; j < model.num_joints(); ++j) {
    const GpRegressor& gp = model.joint_gp(j);
    const Eigen::VectorXd p = gp.kernel().log_params();
    Eigen::VectorXd x(p.size() + 1);
    x << p, gp.log_noise_variance();
    out.push_back(x);
  }
  return out;
}

TrainResult refit_model(const InverseDynamicsModel& model, const TrainOptions& options,
                        const ProgressCallback& progress, RefitStart start) {
  if (model.is_sparse())
    throw Error("refit_model needs an exact GP model; a sparse model keeps its inducing rows, not its training rows");
  std::optional<InverseDynamicsModel> factored;  // only where the model lacks its factors: no copy of them
  const InverseDynamicsModel& exact = model.has_variance() ? model : factored.emplace(model.with_variance());
  TrainOptions o = options;
  o.kernel = model.kernel_name();
  o.robot_prior = model.robot_prior();
  o.gp.scaling = model.output_scaling();
  o.gp.mean = model.mean_kind();
  if (start == RefitStart::CurrentHyperparameters) o.gp.initial_log_params = learned_log_params(model);
  return train_model(exact.training_inputs(), exact.training_targets(), model.joints(), o, progress);
}

}  // namespace gipdyn
