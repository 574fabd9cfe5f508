#include "gipdyn/robot/chain_identification.hpp"

#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <sstream>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

void ChainIdentificationOptions::validate() const {
  if (starts < 1) throw Error("ChainIdentificationOptions::starts must be at least 1 (got " + std::to_string(starts) + ")");
  if (rows < 0) throw Error("ChainIdentificationOptions::rows must be >= 0 (0: every row; got " + std::to_string(rows) + ")");
  if (screening_rows < 0)
    throw Error("ChainIdentificationOptions::screening_rows must be >= 0 (0: every row; got " +
                std::to_string(screening_rows) + ")");
  if (refined_starts < 1)
    throw Error("ChainIdentificationOptions::refined_starts must be at least 1 (got " +
                std::to_string(refined_starts) + ")");
  if (!(length_scale > 0.0) || !std::isfinite(length_scale))
    throw Error("ChainIdentificationOptions::length_scale must be a positive length in metres");
  if (max_evaluations < 1) throw Error("ChainIdentificationOptions::max_evaluations must be at least 1");
  if (threads < 0) throw Error("ChainIdentificationOptions::threads must be >= 0 (0: one per core)");
  if (!(gravity > 0.0) || !std::isfinite(gravity))
    throw Error("ChainIdentificationOptions::gravity must be a positive acceleration in m/s^2");
}

std::string to_string(ChainIdentificationStatus status) {
  switch (status) {
    case ChainIdentificationStatus::Converged: return "converged";
    case ChainIdentificationStatus::MaxEvaluations: return "max-evaluations";
    case ChainIdentificationStatus::Failed: return "failed";
  }
  return "failed";
}

namespace {

constexpr int kDhPerJoint = 4;  // a, alpha, d, theta
constexpr int kGravityParameters = 2;  // rotation of -z about the base's x and y axes

// Placeholder links: the regressor depends on the geometry alone.
LinkInertial placeholder_link() {
  LinkInertial l;
  l.mass = 1.0;
  l.inertia = 0.01 * Eigen::Matrix3d::Identity();
  return l;
}

double wrap_angle(double x) { return std::remainder(x, 2.0 * M_PI); }

// Joint limits spanning the logged positions and speeds: the identified
// chain's, which a RobotModel must have; the dynamics do not use them.
std::vector<JointLimits> logged_limits(const Eigen::MatrixXd& X, int n) {
  std::vector<JointLimits> limits(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double lo = X.col(i).minCoeff(), hi = X.col(i).maxCoeff();
    const double margin = 0.1 * (hi - lo) + 1e-3;
    limits[static_cast<size_t>(i)] = JointLimits{lo - margin, hi + margin, std::max(1e-3, X.col(n + i).cwiseAbs().maxCoeff())};
  }
  return limits;
}

// The chain described by the geometry vector k (4 DH numbers per joint, then
// two gravity angles).
RobotModel chain_from(const Eigen::VectorXd& k, const JointTypes& joints, const std::vector<JointLimits>& limits,
                      double g, bool tidy) {
  const int n = joints.size();
  std::vector<JointSpec> specs(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    JointSpec& s = specs[static_cast<size_t>(i)];
    s.name = "joint" + std::to_string(i + 1);
    s.type = joints[i];
    const double* p = k.data() + kDhPerJoint * i;
    s.dh = DhParameters{p[0], tidy ? wrap_angle(p[1]) : p[1], p[2], tidy ? wrap_angle(p[3]) : p[3]};
    s.link = placeholder_link();
    s.limits = limits[static_cast<size_t>(i)];
  }
  const Eigen::Vector2d r = k.tail<kGravityParameters>();
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -g);
  if (r.norm() > 0.0)
    gravity = Eigen::AngleAxisd(r.norm(), Eigen::Vector3d(r(0), r(1), 0.0).normalized()) * gravity;
  return RobotModel::from_dh("identified chain", std::move(specs), gravity);
}

// Residual of the stacked torques after the inertial least squares, for
// Eigen's Levenberg-Marquardt (MINPACK's lmdif through NumericalDiff).
struct ProjectedResidual {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;

  const JointTypes* joints;
  const std::vector<JointLimits>* limits;
  const Eigen::MatrixXd* X;
  Eigen::VectorXd y;  // sample-major, as stacked_regressor orders its rows
  double gravity;
  mutable int calls = 0;

  int inputs() const { return kDhPerJoint * joints->size() + kGravityParameters; }
  int values() const { return static_cast<int>(y.size()); }

  int operator()(const Eigen::VectorXd& k, Eigen::VectorXd& r) const {
    ++calls;
    if (!k.allFinite()) {
      r.setConstant(y.size(), 1e10);
      return 0;
    }
    const RobotModel robot = chain_from(k, *joints, *limits, gravity, false);
    const Eigen::MatrixXd Phi = stacked_regressor(robot, *X, false);
    // Minimum-norm least squares: a chain has fewer base parameters than 10
    // per link, and the combinations the log cannot tell apart do not change
    // the residual.
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(Phi);
    cod.setThreshold(1e-10);
    r = Phi * cod.solve(y) - y;
    if (!r.allFinite()) r.setConstant(y.size(), 1e10);
    return 0;
  }
};

// `wanted` rows with a constant step from the first row to the last (all
// rows for 0 or more than there are). Not training_data.hpp's
// constant_step_indices, which steps by rows / count from the first and
// never reaches the last: the chain's documented figures were measured with
// these rows.
std::vector<Eigen::Index> constant_step_rows(Eigen::Index total, int wanted) {
  const Eigen::Index m = wanted <= 0 || wanted >= total ? total : wanted;
  std::vector<Eigen::Index> idx(static_cast<size_t>(m));
  for (Eigen::Index i = 0; i < m; ++i) idx[static_cast<size_t>(i)] = m == 1 ? 0 : i * (total - 1) / (m - 1);
  return idx;
}

ChainIdentificationStatus status_of(int info) {
  using LM = Eigen::LevenbergMarquardtSpace::Status;
  switch (info) {
    case LM::RelativeReductionTooSmall:
    case LM::RelativeErrorTooSmall:
    case LM::RelativeErrorAndReductionTooSmall:
    case LM::CosinusTooSmall:
    case LM::FtolTooSmall:
    case LM::XtolTooSmall:
    case LM::GtolTooSmall:
      return ChainIdentificationStatus::Converged;
    case LM::TooManyFunctionEvaluation:
      return ChainIdentificationStatus::MaxEvaluations;
    default:
      return ChainIdentificationStatus::Failed;
  }
}

// Start s's geometry: its own generator, so a start does not depend on the others or on the threads.
Eigen::VectorXd random_start(int joints, const ChainIdentificationOptions& o, int s) {
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ULL + static_cast<std::uint64_t>(s) + 1);
  std::uniform_real_distribution<double> length(-o.length_scale, o.length_scale), angle(-M_PI, M_PI);
  Eigen::VectorXd k(kDhPerJoint * joints + kGravityParameters);
  // Uniform angles: starting from right angles (0, +-90, 180 degrees), where
  // most arms' twists are, found the optimum less often (docs/results/training.md).
  for (int i = 0; i < joints; ++i) {
    k(kDhPerJoint * i) = length(rng);
    k(kDhPerJoint * i + 1) = angle(rng);
    k(kDhPerJoint * i + 2) = length(rng);
    k(kDhPerJoint * i + 3) = angle(rng);
  }
  // Gravity starts along the first joint's axis, where most arms are mounted,
  // tilted by a random amount up to 90 degrees on the odd starts.
  k.tail<kGravityParameters>().setZero();
  if (s % 2 == 1) {
    const double tilt = 0.5 * M_PI * std::uniform_real_distribution<double>(0.0, 1.0)(rng), dir = angle(rng);
    k(k.size() - 2) = tilt * std::cos(dir);
    k(k.size() - 1) = tilt * std::sin(dir);
  }
  return k;
}

struct Subsample {
  Eigen::MatrixXd X;
  Eigen::VectorXd y;  // sample-major
};

Subsample subsample(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, int rows) {
  const std::vector<Eigen::Index> idx = constant_step_rows(X.rows(), rows);
  const Eigen::MatrixXd Yt = Y(idx, Eigen::all).transpose();
  return {X(idx, Eigen::all), Eigen::Map<const Eigen::VectorXd>(Yt.data(), Yt.size())};
}

// Levenberg-Marquardt from k on the subsample; k ends at the point reached.
ChainStartReport search(const Subsample& data, const JointTypes& joints, const std::vector<JointLimits>& limits,
                        double gravity, int max_evaluations, Eigen::VectorXd& k) {
  ProjectedResidual f{&joints, &limits, &data.X, data.y, gravity};
  Eigen::NumericalDiff<ProjectedResidual> diff(f);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<ProjectedResidual>, double> lm(diff);
  lm.parameters.maxfev = max_evaluations;
  const int info = lm.minimize(k);
  Eigen::VectorXd r;
  f(k, r);
  ChainStartReport rep;
  rep.evaluations = diff.calls;
  rep.status = status_of(info);
  rep.residual_rms = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
  if (!std::isfinite(rep.residual_rms) || rep.residual_rms >= 1e9) rep.status = ChainIdentificationStatus::Failed;
  return rep;
}

}  // namespace

ChainIdentification identify_chain(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                                   const ChainIdentificationOptions& options, const ProgressCallback& progress) {
  options.validate();
  validate_training_data(X, Y, joints);
  use_single_threaded_blas();
  const auto t0 = std::chrono::steady_clock::now();
  const int n = joints.size();
  const Subsample screen = subsample(X, Y, options.screening_rows), fine = subsample(X, Y, options.rows);
  const std::vector<JointLimits> limits = logged_limits(X, n);
  const int parameters = kDhPerJoint * n + kGravityParameters;
  if (std::min(screen.y.size(), fine.y.size()) <= parameters)
    throw Error("identify_chain: " + std::to_string(std::min(screen.X.rows(), fine.X.rows())) +
                " rows give too few torques for a " + std::to_string(n) +
                "-joint chain; use more rows (ChainIdentificationOptions::rows, or a longer log)");
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  auto report = [&](const char* stage, int s, int of, const ChainStartReport& rep, long rows) {
    if (!progress) return;
    ProgressEvent e;
    e.restart = s;
    e.rows = rows;
    e.iteration = rep.evaluations;
    e.objective = rep.residual_rms;
    e.seconds = elapsed();
    e.message = std::string(stage) + " " + std::to_string(s + 1) + " of " + std::to_string(of) + ": " +
                to_string(rep.status);
    progress(e);
  };

  // Stage 1: every start on the small subsample.
  ChainIdentification result;
  result.rows = fine.X.rows();
  result.screening_rows = screen.X.rows();
  result.starts.resize(static_cast<size_t>(options.starts));
  std::vector<Eigen::VectorXd> points(static_cast<size_t>(options.starts));
  run_tasks(options.starts, worker_threads(options.threads, options.starts), [&](int s) {
    Eigen::VectorXd k = random_start(n, options, s);
    const ChainStartReport rep = search(screen, joints, limits, options.gravity, options.max_evaluations, k);
    result.starts[static_cast<size_t>(s)] = rep;
    points[static_cast<size_t>(s)] = k;
    report("start", s, options.starts, rep, screen.X.rows());
  });

  // Stage 2: the leaders, on the larger subsample, from where they stopped.
  std::vector<int> order;
  for (int s = 0; s < options.starts; ++s)
    if (result.starts[static_cast<size_t>(s)].status != ChainIdentificationStatus::Failed) order.push_back(s);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.starts[static_cast<size_t>(a)].residual_rms < result.starts[static_cast<size_t>(b)].residual_rms;
  });
  if (order.empty()) {
    result.seconds = elapsed();
    result.message = "identify_chain: no start gave a finite residual; check the log for outliers, or raise "
                     "ChainIdentificationOptions::starts";
    return result;
  }
  order.resize(std::min<size_t>(order.size(), static_cast<size_t>(options.refined_starts)));
  result.refined.resize(order.size());
  const int refined = static_cast<int>(order.size());
  run_tasks(refined, worker_threads(options.threads, refined), [&](int i) {
    Eigen::VectorXd& k = points[static_cast<size_t>(order[static_cast<size_t>(i)])];
    result.refined[static_cast<size_t>(i)] = search(fine, joints, limits, options.gravity, options.max_evaluations, k);
    report("refined", i, refined, result.refined[static_cast<size_t>(i)], fine.X.rows());
  });
  int best = -1;
  for (int i = 0; i < refined; ++i) {
    const ChainStartReport& rep = result.refined[static_cast<size_t>(i)];
    if (rep.status == ChainIdentificationStatus::Failed) continue;
    if (best < 0 || rep.residual_rms < result.refined[static_cast<size_t>(best)].residual_rms) best = i;
  }
  result.seconds = elapsed();
  if (best < 0) {
    result.message = "identify_chain: no refined start gave a finite residual; check the log for outliers";
    return result;
  }
  result.status = result.refined[static_cast<size_t>(best)].status;
  result.residual_rms = result.refined[static_cast<size_t>(best)].residual_rms;
  result.robot =
      chain_from(points[static_cast<size_t>(order[static_cast<size_t>(best)])], joints, limits, options.gravity, true);
  return result;
}

std::string ChainIdentification::brief_report() const {
  std::ostringstream os;
  os << "chain identification: " << to_string(status);
  if (!ok()) return os.str() + ": " + message;
  std::vector<double> rms;
  for (const ChainStartReport& s : starts)
    if (s.status != ChainIdentificationStatus::Failed) rms.push_back(s.residual_rms);
  std::sort(rms.begin(), rms.end());
  int near = 0;
  for (const ChainStartReport& s : refined) near += s.status != ChainIdentificationStatus::Failed && s.residual_rms <= 1.05 * residual_rms;
  char line[320];
  std::snprintf(line, sizeof line,
                ", residual %.4g RMS on %ld rows (the torques' unit); %d of the %zu best of %zu starts within 5 %% of "
                "it; on the %ld screening rows the starts ended at %.3g to %.3g; %.1f s",
                residual_rms, rows, near, refined.size(), starts.size(), screening_rows,
                rms.empty() ? 0.0 : rms.front(), rms.empty() ? 0.0 : rms.back(), seconds);
  os << line;
  return os.str();
}

}  // namespace gipdyn
