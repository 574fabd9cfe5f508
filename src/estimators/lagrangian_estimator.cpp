#include "gipdyn/estimators/lagrangian_estimator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/gp/lagrangian_weight_space_nll.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/training_data.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

// The plateau rule of LIP's searches (LagrangianEstimator::fit).
constexpr int kLipPlateauEvaluations = 20;
constexpr double kLipPlateauDecrease = 0.1;
// A warm start's least torque values per hyperparameter (LagrangianOptions::warm_start_rows).
constexpr long kWarmStartValuesPerHyperparameter = 10;

// Sample-major stacking: entry r n + i is Y(r, i).
Eigen::VectorXd stack_rows(const Eigen::MatrixXd& Y) {
  const Eigen::MatrixXd Yt = Y.transpose();
  return Eigen::Map<const Eigen::VectorXd>(Yt.data(), Yt.size());
}

// The negative log marginal likelihood and its gradient with respect to
// (kernel log-parameters, log noise variance per joint).
struct Evaluation {
  bool ok = false;
  std::string message;
  double nll = 0.0;
  double jitter = 0.0;
  Eigen::VectorXd gradient;
};

// The lower triangle of the torque covariance of X plus each joint's noise
// variance on the diagonal (sample-major).
void build_covariance(const LagrangianKernel& kernel, const Eigen::MatrixXd& X, const Eigen::VectorXd& noise,
                      Eigen::MatrixXd& K) {
  const Eigen::Index n = noise.size();
  kernel.torque_gram_lower(X, K);
  for (Eigen::Index r = 0; r < X.rows(); ++r)
    for (Eigen::Index i = 0; i < n; ++i) K(r * n + i, r * n + i) += noise(i);
}

class LikelihoodWorkspace {
 public:
  LikelihoodWorkspace(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, int n, const JitterPolicy& jitter)
      : X_(X), y_(y), n_(n), jitter_(jitter) {}

  // K + noise on the diagonal, factorised in K_; alpha_ = K^-1 y.
  CholeskyResult factorise(const LagrangianKernel& kernel, const Eigen::VectorXd& noise) {
    auto build = [&](Eigen::MatrixXd& K) { build_covariance(kernel, X_, noise, K); };
    build(K_);
    const CholeskyResult c = cholesky_with_jitter(K_, build, jitter_);
    if (!c.ok()) return c;
    alpha_ = y_;
    cholesky_solve(K_, alpha_);
    return c;
  }

  Evaluation evaluate(const LagrangianKernel& kernel, const Eigen::VectorXd& noise, bool want_gradient) {
    Evaluation e;
    const CholeskyResult c = factorise(kernel, noise);
    if (!c.ok()) {
      e.message = c.message;
      return e;
    }
    e.jitter = c.jitter;
    e.nll = gaussian_nll(y_.dot(alpha_), 2.0 * K_.diagonal().array().log().sum(), y_.size());
    if (!std::isfinite(e.nll)) {
      e.message = "the marginal likelihood is not finite";
      return e;
    }
    e.ok = true;
    if (!want_gradient) return e;
    // W = K^-1 - alpha alpha^T (lower triangle): dNLL/dtheta = 1/2 <W, dK/dtheta>.
    if (!cholesky_inverse_in_place(K_)) {
      e.ok = false;
      e.message = "cannot invert the kernel matrix";
      return e;
    }
    K_.triangularView<Eigen::Lower>() -= alpha_ * alpha_.transpose();
    const int P = kernel.num_params();
    e.gradient = Eigen::VectorXd::Zero(P + n_);
    kernel.add_gradient(X_, K_, e.gradient.head(P));
    e.gradient.head(P) *= 0.5;
    for (Eigen::Index r = 0; r < X_.rows(); ++r)
      for (int i = 0; i < n_; ++i) e.gradient(P + i) += 0.5 * noise(i) * K_(r * n_ + i, r * n_ + i);
    return e;
  }

  const Eigen::VectorXd& alpha() const { return alpha_; }

 private:
  const Eigen::MatrixXd& X_;
  const Eigen::VectorXd& y_;
  int n_;
  JitterPolicy jitter_;
  Eigen::MatrixXd K_;
  Eigen::VectorXd alpha_;
};

class LagrangianQueryWorkspace final : public QueryWorkspace {
 public:
  LagrangianQueryWorkspace(const LagrangianKernel& kernel, const Eigen::MatrixXd& X, const Eigen::VectorXd& alpha,
                           double scale)
      : QueryWorkspace(kernel.joints().size()), kernel_(kernel), states_(X.transpose()), alpha_(alpha), scale_(scale), scratch_(kernel),
        block_(kernel.joints().size(), kernel.joints().size()), tau_(kernel.joints().size()) {}

  void predict(const double* x, double* tau) override {
    const Eigen::Index n = tau_.size();
    tau_.setZero();
    for (Eigen::Index r = 0; r < states_.cols(); ++r) {
      kernel_.torque_block(x, states_.col(r).data(), scratch_, block_);
      tau_.noalias() += block_ * alpha_.segment(r * n, n);
    }
    Eigen::Map<Eigen::VectorXd>(tau, n) = scale_ * tau_;
  }
  bool allocation_free() const override { return true; }

 private:
  const LagrangianKernel& kernel_;
  const Eigen::MatrixXd states_;  // the training states transposed: each query reads them contiguously
  const Eigen::VectorXd& alpha_;
  double scale_;
  LagrangianKernel::PairScratch scratch_;
  Eigen::MatrixXd block_;
  Eigen::VectorXd tau_;
};

class LagrangianWeightSpaceQueryWorkspace final : public QueryWorkspace {
 public:
  LagrangianWeightSpaceQueryWorkspace(std::shared_ptr<const LagrangianWeightSpaceMean> mean, double scale)
      : QueryWorkspace(mean->num_joints()), mean_(std::move(mean)), scale_(scale), workspace_(*mean_) {}

  void predict(const double* x, double* tau) override {
    mean_->mean(x, workspace_, tau);
    Eigen::Map<Eigen::VectorXd>(tau, mean_->num_joints()) *= scale_;
  }
  bool allocation_free() const override { return true; }

 private:
  std::shared_ptr<const LagrangianWeightSpaceMean> mean_;
  double scale_;
  LagrangianWeightSpaceMean::Workspace workspace_;
};

// LIP's starts. The coupled likelihood has optima that explain whole joints
// as noise (thousands of nats above the best, with test errors orders of
// magnitude worse; docs/results/training.md), and which start reaches the better one
// depends on the starting noise. So the data-driven start x0 is tried with the
// starting noise at 1, 0.1 and 0.01 times SearchSettings::initial_noise_fraction
// (never below the floor); the restarts perturb the first of them, seeded.
std::vector<Eigen::VectorXd> lip_start_points(const Eigen::VectorXd& x0, const OptimizerOptions& bounds, int n,
                                              const SearchSettings& o) {
  const int noise_starts = 3;
  std::vector<Eigen::VectorXd> starts;
  for (int r = 0; r < noise_starts; ++r) {
    starts.push_back(x0);
    if (r > 0) starts.back().tail(n).array() += std::log(std::pow(0.1, r));
  }
  for (Eigen::VectorXd& start : restart_points(x0, o, 7919ULL)) starts.push_back(std::move(start));
  for (Eigen::VectorXd& start : starts) start = start.cwiseMax(bounds.lower_bounds).cwiseMin(bounds.upper_bounds);
  return starts;
}

// One start's NLL of the stacked torques y over the states X: its own kernel
// and workspace, or the shared weight-space likelihood where there is one.
Objective lip_objective(const LagrangianKernel& kernel, const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                        const JitterPolicy& jitter, std::shared_ptr<const LagrangianWeightSpaceNll> weight_space) {
  const int P = kernel.num_params(), n = kernel.joints().size();
  auto trial = std::make_shared<LagrangianKernel>(kernel);
  auto ws = std::make_shared<LikelihoodWorkspace>(X, y, n, jitter);  // allocates only when it evaluates
  return [weight_space, ws, trial, P, n](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& g) {
    trial->set_log_params(x.head(P));
    const Eigen::VectorXd noise = x.tail(n).array().exp();
    if (weight_space) {
      // Where weight space is too ill-conditioned (NotPositiveDefinite), kernel space and its jitter evaluate.
      const NllEvaluation w = weight_space->evaluate(*trial, noise, true);
      if (w.ok() || w.status != NllEvaluation::Status::NotPositiveDefinite) {
        if (!w.ok()) return false;
        f = w.nll;
        g = w.gradient;
        return true;
      }
    }
    const Evaluation e = ws->evaluate(*trial, noise, true);
    if (!e.ok) return false;
    f = e.nll;
    g = e.gradient;
    return true;
  };
}

// Where LIP's likelihood on `rows` states is evaluated, and what it costs in
// memory. Weight space (LagrangianWeightSpaceNll) is used where the kernel has
// fewer features than there are torques; it equals kernel space up to
// rounding at a cost that does not grow with the rows past the features'
// products. Kernel space holds nothing between evaluations, and each
// evaluation one (rows n)^2 matrix (the kernel, its factor and then its
// inverse in place).
struct LikelihoodSpace {
  bool weight_space = false;
  double held_bytes = 0.0;        // the features and their products, shared by the starts
  double evaluation_bytes = 0.0;  // one evaluation in flight
  double total_bytes() const { return held_bytes + evaluation_bytes; }
};

double kernel_space_bytes(Eigen::Index rows, int joints) {
  const double system = static_cast<double>(rows) * joints;
  return 8.0 * system * system;
}

LikelihoodSpace likelihood_space(const LagrangianKernel& structure, Eigen::Index rows) {
  LikelihoodSpace space;
  space.weight_space = LagrangianWeightSpaceNll::worthwhile(structure, rows);
  if (space.weight_space) {
    space.held_bytes = LagrangianWeightSpaceNll::bytes(structure, rows);
    space.evaluation_bytes = LagrangianWeightSpaceNll::evaluation_bytes(structure, rows);
  } else {
    space.evaluation_bytes = kernel_space_bytes(rows, structure.joints().size());
  }
  return space;
}

// The one coupled fit's report, per joint, with each joint's noise as a share
// of its torque variance, as for GP joints.
std::vector<JointReport> joint_reports(const JointReport& shared, const Eigen::VectorXd& noise,
                                       const Eigen::VectorXd& joint_variance) {
  std::vector<JointReport> joints;
  for (Eigen::Index i = 0; i < noise.size(); ++i) {
    JointReport j = shared;
    j.joint = static_cast<int>(i);
    j.noise_variance = noise(i) / joint_variance(i);
    j.noise_share = j.noise_variance;
    joints.push_back(j);
  }
  return joints;
}

}  // namespace

std::unique_ptr<QueryWorkspace> LagrangianEstimator::make_query_workspace() const {
  if (weight_space_) return std::make_unique<LagrangianWeightSpaceQueryWorkspace>(weight_space_, scale_);
  return std::make_unique<LagrangianQueryWorkspace>(kernel_, X_, alpha_, scale_);
}

LagrangianEstimator::LagrangianEstimator(LagrangianKernel kernel, Eigen::VectorXd noise_variances, double torque_scale,
                                         Eigen::MatrixXd X, Eigen::VectorXd alpha)
    : kernel_(std::move(kernel)), noise_(std::move(noise_variances)), scale_(torque_scale), X_(std::move(X)),
      alpha_(std::move(alpha)) {
  const int n = kernel_.joints().size();
  if (noise_.size() != n || X_.cols() != 3 * n || alpha_.size() != X_.rows() * n || !(scale_ > 0.0))
    throw Error("LagrangianEstimator: inconsistent shapes (noise, training states, weights or scale)");
  if (LagrangianWeightSpaceMean::worthwhile(kernel_, X_.rows()))
    weight_space_ = std::make_shared<const LagrangianWeightSpaceMean>(kernel_, X_, alpha_);
}

void LagrangianOptions::validate() const {
  search.validate();
  if (warm_start_rows < 0) throw Error("LagrangianOptions::warm_start_rows must be >= 0 (0: no warm start)");
  if (warm_start_rows > 0 && warm_start_rows < static_cast<int>(kMinTrainingRows))
    throw Error("LagrangianOptions::warm_start_rows must be 0 or at least " + std::to_string(kMinTrainingRows));
}

LagrangianEstimator::FitOutcome LagrangianEstimator::fit(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                                                         const JointTypes& joints, const LagrangianOptions& options,
                                                         const ProgressCallback& progress) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  options.validate();
  const SearchSettings& o = options.search;
  const bool friction = options.friction;
  validate_training_data(X, Y, joints);
  const int n = joints.size();
  // The hyperparameters may be learned on a constant-step subsample: each
  // evaluation then costs (H/N)^3 of one on every row, and the model is
  // conditioned on every row once, by one factorisation.
  const bool subsampled = o.hyperparameter_rows > 0 && X.rows() > o.hyperparameter_rows;
  const std::vector<Eigen::Index> rows =
      subsampled ? constant_step_indices(X.rows(), o.hyperparameter_rows) : std::vector<Eigen::Index>();
  const Eigen::MatrixXd X_subsample = subsampled ? Eigen::MatrixXd(X(rows, Eigen::all)) : Eigen::MatrixXd();
  const Eigen::MatrixXd Y_subsample = subsampled ? Eigen::MatrixXd(Y(rows, Eigen::all)) : Eigen::MatrixXd();
  const Eigen::MatrixXd& Xh = subsampled ? X_subsample : X;
  const Eigen::MatrixXd& Yh = subsampled ? Y_subsample : Y;
  const LagrangianKernel structure(joints, friction, options.serial_chain);
  const LikelihoodSpace search_space = likelihood_space(structure, Xh.rows());
  const LikelihoodSpace final_space = likelihood_space(structure, X.rows());
  // What a fit on every row needs, in the words of its memory errors.
  const std::string kernel_space_matrix =
      " (one " + std::to_string(static_cast<long>(X.rows()) * n) + "-square matrix)";
  const std::string what = "lip on " + std::to_string(X.rows()) + " rows of " + std::to_string(n) + " joints";
  // The starts' evaluations are freed before the final fit's.
  require_memory(std::max(final_space.total_bytes(), search_space.total_bytes()),
                 what + (final_space.weight_space ? std::string() : kernel_space_matrix),
                 subsampled ? "train on fewer rows" : "train on fewer rows, or learn the hyperparameters on a "
                                                      "subsample (SearchSettings::hyperparameter_rows) and train on "
                                                      "fewer rows");
  use_single_threaded_blas();

  // One scale for all joints: the energies couple them, so no per-joint
  // scaling. Scale, start and bounds come from the rows the hyperparameters
  // are learned on, so that they are those of a fit on the subsample alone.
  const double scale = std::sqrt(std::max(Yh.squaredNorm() / static_cast<double>(Yh.size()), 1e-300));
  const Eigen::VectorXd y = stack_rows(Y) / scale;
  const Eigen::VectorXd y_subsample = subsampled ? Eigen::VectorXd(stack_rows(Yh) / scale) : Eigen::VectorXd();
  const Eigen::VectorXd& yh = subsampled ? y_subsample : y;
  Eigen::VectorXd joint_variance(n);
  for (int i = 0; i < n; ++i)
    joint_variance(i) = std::max(Yh.col(i).squaredNorm() / static_cast<double>(Yh.rows()) / (scale * scale), 1e-12);

  LagrangianKernel kernel(joints, friction, options.serial_chain);
  kernel.initialize(Xh, 1.0);
  const int P = kernel.num_params();
  Eigen::VectorXd x0(P + n);
  x0.head(P) = kernel.log_params();
  x0.tail(n) = (o.initial_noise_fraction * joint_variance).array().log();
  OptimizerOptions opt = o.optimizer;
  opt.lower_bounds = Eigen::VectorXd::Constant(P + n, -30.0);
  opt.upper_bounds = Eigen::VectorXd::Constant(P + n, 30.0);
  opt.lower_bounds.tail(n) = (o.min_noise_fraction * joint_variance).array().log();
  opt.upper_bounds.tail(n) = (10.0 * joint_variance).array().log();
  kernel.restrict_log_params(X, opt.lower_bounds.head(P), opt.upper_bounds.head(P));
  // LIP's many coupled hyperparameters leave its NLL long flat valleys, along
  // which L-BFGS creeps for many evaluations toward the gradient tolerance
  // while the likelihood no longer moves. Unless the caller set a plateau
  // rule, a search ends once 20 evaluations have gained less than 0.1 nat: a
  // likelihood ratio of 1.1, hyperparameters the data cannot tell apart.
  if (opt.plateau_evaluations == 0) {
    opt.plateau_evaluations = kLipPlateauEvaluations;
    opt.plateau_decrease = kLipPlateauDecrease;
  }

  FitOutcome out;
  JointReport shared;
  shared.coupled = true;
  const std::vector<Eigen::VectorXd> start_points = lip_start_points(x0, opt, n, o);
  // One fit is a single coupled optimisation whose factorisations run on one
  // core, so the starts run side by side (SearchSettings::threads, 0: all at
  // once, sharing the cores) as far as memory allows. Each start depends on
  // its starting point alone and BLAS runs on one thread, so the kept optimum
  // does not depend on how many run at once. Screening
  // (SearchSettings::start_screening_evaluations) pays here: the starts that
  // reach the noise-explained optima show it early, while the good ones spend
  // most of their evaluations on the last few nats.
  // A warm start searches first on a constant-step subsample of the
  // hyperparameter rows; the search on the rows themselves then continues
  // from the subsample's best optimum alone. The subsample must pin the
  // hyperparameters down (LagrangianOptions::warm_start_rows): with too few
  // torques per hyperparameter its optimum lies in another basin.
  const bool warm = options.warm_start_rows > 0 && Xh.rows() >= 2 * static_cast<Eigen::Index>(options.warm_start_rows) &&
                    static_cast<long>(options.warm_start_rows) * n >= kWarmStartValuesPerHyperparameter * (P + n);
  const std::vector<Eigen::Index> warm_rows =
      warm ? constant_step_indices(Xh.rows(), options.warm_start_rows) : std::vector<Eigen::Index>();
  const Eigen::MatrixXd Xw = warm ? Eigen::MatrixXd(Xh(warm_rows, Eigen::all)) : Eigen::MatrixXd();
  const Eigen::VectorXd yw = warm ? Eigen::VectorXd(stack_rows(Yh(warm_rows, Eigen::all)) / scale) : Eigen::VectorXd();
  const std::string name = estimator_name(EstimatorFamily::Lagrangian, &EstimatorSpec::friction, friction);
  // The search from `from` on the states Xs with torques ys; weight_space:
  // its weight-space likelihood, where it has one.
  std::shared_ptr<const LagrangianWeightSpaceNll> weight_space;
  auto search_on = [&](const Eigen::MatrixXd& Xs, const Eigen::VectorXd& ys, const std::vector<Eigen::VectorXd>& from) {
    const LikelihoodSpace space = likelihood_space(structure, Xs.rows());
    // The starts share one weight-space likelihood: its features depend on the states alone.
    weight_space = space.weight_space ? std::make_shared<const LagrangianWeightSpaceNll>(kernel, Xs, ys)
                                      : std::shared_ptr<const LagrangianWeightSpaceNll>();
    SearchOptions search;
    search.optimizer = opt;
    search.optimizer.gradient_tolerance = o.gradient_tolerance_per_row * static_cast<double>(Xs.rows()) * n;
    search.screening_evaluations = o.start_screening_or_default();
    search.threads = sharing_threads(o.threads, static_cast<int>(from.size()));
    search.bytes_per_start = space.evaluation_bytes;
    return search_hyperparameters(
        from, [&](int) { return lip_objective(kernel, Xs, ys, o.jitter, weight_space); }, search,
        [&](int r) -> ProgressCallback {
          if (!progress) return {};
          return [&, r](const ProgressEvent& optimizer_event) {
            ProgressEvent e = optimizer_event;
            e.estimator = name;
            e.restart = r;
            e.rows = static_cast<long>(Xs.rows());
            e.seconds = seconds();
            progress(e);
          };
        });
  };
  SearchResult found = search_on(warm ? Xw : Xh, warm ? yw : yh, start_points);
  if (warm) {
    shared.warm_start_evaluations = found.evaluations;
    shared.restart_nlls = found.best.objectives;
    const int screening = found.screening_evaluations;
    if (found.best.found()) {
      found = search_on(Xh, yh, {found.best.kept.x});
      found.screening_evaluations = screening;
    } else {
      found.evaluations = 0;
    }
  }
  const BestOfStarts& starts = found.best;
  shared.evaluations = found.evaluations;
  if (!warm) shared.restart_nlls = starts.objectives;
  const OptimizerResult& kept = starts.kept;
  shared.status = kept.status;
  shared.message = kept.message;
  shared.grad_norm = kept.grad_norm;
  out.report.seconds = seconds();
  if (!starts.found()) {
    out.report.message = "lip: " + (kept.message.empty() ? std::string("no start could be evaluated") : kept.message);
    return out;
  }
  kernel.set_log_params(kept.x.head(P));
  const Eigen::VectorXd noise = kept.x.tail(n).array().exp();
  if (subsampled) shared.hyperparameter_rows = static_cast<long>(Xh.rows());
  shared.screening_evaluations = found.screening_evaluations;
  Evaluation final_fit;
  Eigen::VectorXd alpha;
  NllEvaluation weight_space_fit;
  if (subsampled) {  // one step without iterations, the longest of a fit on a long log in kernel space
    char at[32];
    std::snprintf(at, sizeof at, "%.1f s", seconds());
    send_note(progress, name,
              "conditioning on all " + std::to_string(X.rows()) + " rows with the hyperparameters found (" +
                  (final_space.weight_space
                       ? std::string("in weight space")
                       : "one factorisation of a " + std::to_string(static_cast<long>(X.rows()) * n) +
                             "-square matrix") +
                  ", " + at + ")");
  }
  if (final_space.weight_space) {
    // Without a subsample the search's likelihood is the final fit's.
    const auto final_weight_space =
        subsampled ? std::make_shared<const LagrangianWeightSpaceNll>(kernel, X, y) : weight_space;
    weight_space_fit = final_weight_space->evaluate(kernel, noise, false, &alpha);
  }
  if (final_space.weight_space && weight_space_fit.status != NllEvaluation::Status::NotPositiveDefinite) {
    final_fit.ok = weight_space_fit.ok();
    final_fit.message = weight_space_fit.message;
    final_fit.nll = weight_space_fit.nll;
    final_fit.jitter = weight_space_fit.jitter;
  } else {
    if (final_space.weight_space)  // too ill-conditioned there: kernel space's (N n)^2 matrix after all
      require_memory(kernel_space_bytes(X.rows(), n), what + kernel_space_matrix, "train on fewer rows");
    LikelihoodWorkspace final_ws(X, y, n, o.jitter);
    final_fit = final_ws.evaluate(kernel, noise, false);
    alpha = final_ws.alpha();
  }
  if (!final_fit.ok) {
    out.report.message = "lip: final fit failed: " + final_fit.message;
    return out;
  }
  shared.nll = final_fit.nll;
  shared.jitter = final_fit.jitter;
  shared.seconds = seconds();
  out.report.joints = joint_reports(shared, noise, joint_variance);
  out.report.status = combine_joint_statuses(out.report.joints);
  out.estimator = std::make_unique<LagrangianEstimator>(kernel, noise * scale * scale, scale, X, std::move(alpha));
  return out;
}

Eigen::MatrixXd LagrangianEstimator::state_rows(const Eigen::Ref<const Eigen::MatrixXd>& X, int min_cols,
                                                const char* what) const {
  const int n = joints().size();
  if (X.cols() < min_cols * n)
    throw Error(std::string(what) + ": " + std::to_string(X.cols()) + " columns given, at least " +
                std::to_string(min_cols * n) + " expected for " + std::to_string(n) + " joints");
  if (!X.allFinite()) throw Error(std::string(what) + ": the input has NaN or infinite values");
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(X.rows(), 3 * n);
  full.leftCols(std::min<Eigen::Index>(X.cols(), 3 * n)) = X.leftCols(std::min<Eigen::Index>(X.cols(), 3 * n));
  return full;
}

Eigen::MatrixXd LagrangianEstimator::predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  const int n = joints().size();
  if (X.cols() != 3 * n)
    throw Error("lip predict: " + std::to_string(X.cols()) + " columns given, " + std::to_string(3 * n) +
                " expected (q, qd, qdd of " + std::to_string(n) + " joints)");
  if (weight_space_) return weight_space_->mean(X) * scale_;
  Eigen::MatrixXd tau(X.rows(), n);
  constexpr Eigen::Index kRows = 256;  // bounds the (rows n) x (N n) cross-covariance
  for (Eigen::Index r0 = 0; r0 < X.rows(); r0 += kRows) {
    const Eigen::Index m = std::min(kRows, X.rows() - r0);
    const Eigen::VectorXd stacked = kernel_.torque_covariance(X.middleRows(r0, m), X_) * alpha_ * scale_;
    tau.middleRows(r0, m) = Eigen::Map<const Eigen::MatrixXd>(stacked.data(), n, m).transpose();
  }
  return tau;
}

LagrangianEstimator LagrangianEstimator::with_variance() const {
  const int n = joints().size();
  const double system = static_cast<double>(X_.rows()) * n;
  require_memory(system * system * 8.0,
                 "lip variances for " + std::to_string(X_.rows()) + " training rows (one " +
                     std::to_string(static_cast<long>(system)) + "-square factor)",
                 "train on fewer rows to get variances");
  LagrangianEstimator out = *this;
  const Eigen::VectorXd noise = noise_ / (scale_ * scale_);
  auto build = [&](Eigen::MatrixXd& K) { build_covariance(kernel_, X_, noise, K); };
  build(out.factor_);
  const CholeskyResult c = cholesky_with_jitter(out.factor_, build);
  if (!c.ok()) throw Error("lip variances: " + c.message);
  return out;
}

Eigen::MatrixXd LagrangianEstimator::predict_std(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  const int n = joints().size();
  if (!has_variance())
    throw Error("lip predict_std: this model holds no factor for variances; use the model from with_variance()");
  if (X.cols() != 3 * n)
    throw Error("lip predict_std: " + std::to_string(X.cols()) + " columns given, " + std::to_string(3 * n) +
                " expected (q, qd, qdd of " + std::to_string(n) + " joints)");
  Eigen::MatrixXd sd(X.rows(), n);
  Eigen::MatrixXd prior(n, n);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const Eigen::RowVectorXd x = X.row(r);
    kernel_.torque_block(x.data(), x.data(), prior);
    // V = L^-1 k(X_train, x): the variance explained by the data is V's column norms.
    Eigen::MatrixXd V = kernel_.torque_covariance(X_, x);
    factor_.triangularView<Eigen::Lower>().solveInPlace(V);
    const Eigen::VectorXd var = prior.diagonal() - V.colwise().squaredNorm().transpose();
    sd.row(r) = (var.cwiseMax(0.0).cwiseSqrt() * scale_).transpose();
  }
  return sd;
}

// The posterior mean of an energy: its covariance with the training torques times alpha.
template <class Covariance>
Eigen::VectorXd LagrangianEstimator::energy(const Eigen::MatrixXd& states, Covariance&& covariance) const {
  Eigen::VectorXd E(states.rows());
  for (Eigen::Index r = 0; r < states.rows(); ++r) {
    const Eigen::VectorXd x = states.row(r).transpose();
    E(r) = covariance(x.data()).dot(alpha_) * scale_;
  }
  return E;
}

Eigen::VectorXd LagrangianEstimator::kinetic_energy(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  return energy(state_rows(X, 2, "lip kinetic_energy"),
                [&](const double* x) { return kernel_.kinetic_torque_covariance(x, X_); });
}

Eigen::VectorXd LagrangianEstimator::potential_energy(const Eigen::Ref<const Eigen::MatrixXd>& Q) const {
  return energy(state_rows(Q, 1, "lip potential_energy"),
                [&](const double* x) { return kernel_.potential_torque_covariance(x, X_); });
}

ModelContainer LagrangianEstimator::to_container() const {
  ModelContainer c;
  c.header["estimator"] = name();
  c.header["joints"] = joints().str();
  c.header["torque_scale"] = scale_;
  c.header["serial_chain"] = kernel_.serial_chain();
  c.header["param_names"] = kernel_.param_names();
  c.add("log_params", kernel_.log_params());
  c.add("noise_variances", noise_);
  c.add("training_states", X_);
  c.add("alpha", alpha_);
  return c;
}

nlohmann::json LagrangianEstimator::summary() const {
  nlohmann::json params;
  const auto names = kernel_.param_names();
  for (size_t k = 0; k < names.size(); ++k) params[names[k]] = std::exp(kernel_.log_params()(static_cast<Eigen::Index>(k)));
  return {{"estimator", name()},
          {"serial_chain", kernel_.serial_chain()},
          {"training_rows", X_.rows()},
          {"noise_variances", std::vector<double>(noise_.data(), noise_.data() + noise_.size())},
          {"torque_scale", scale_},
          {"hyperparameters", params}};
}

LagrangianEstimator LagrangianEstimator::from_container(const ModelContainer& c, const std::string& what) {
  const JointTypes joints = JointTypes::parse(c.header.at("joints").get<std::string>());
  // Files written before the serial-chain kernel have no such entry: theirs was the full one.
  LagrangianKernel kernel(joints, estimator_spec(c.header.at("estimator").get<std::string>()).friction,
                          c.header.value("serial_chain", false));
  const Eigen::MatrixXd& p = c.array("log_params", what);
  const Eigen::MatrixXd& noise = c.array("noise_variances", what);
  const Eigen::MatrixXd& X = c.array("training_states", what);
  const Eigen::MatrixXd& alpha = c.array("alpha", what);
  const double scale = c.header.at("torque_scale").get<double>();
  const int n = joints.size();
  if (p.cols() != 1 || p.rows() != kernel.num_params() || noise.cols() != 1 || noise.rows() != n ||
      X.cols() != 3 * n || alpha.cols() != 1 || alpha.rows() != X.rows() * n || !(scale > 0.0) || !p.allFinite() ||
      !noise.allFinite() || !X.allFinite() || !alpha.allFinite())
    throw Error(what + " is corrupted (lip arrays have the wrong shape or non-finite values); re-save the model");
  kernel.set_log_params(p.col(0));
  return LagrangianEstimator(kernel, noise.col(0), scale, X, alpha.col(0));
}

}  // namespace gipdyn
