// Benchmarks of the GP engine on simulated SCARA (RRPR) and UR10 (RRRRRR) data
// at N = 1000, 2000, 4000: kernel-matrix build, one NLL + gradient evaluation,
// the fused gradient pass alone, the potrf + potri floor, single-query prediction (mean; mean + variance)
// and full training of all joints. After the run, the ratio of one NLL +
// gradient evaluation to the potrf + potri floor is printed per case.
//
//   build/bench/bench_gp                          # everything except full training
//   build/bench/bench_gp --benchmark_filter=Train # full training (minutes)
//   build/bench/bench_gp --benchmark_filter=Vfe   # sparse GP evaluations, N up to 100000
#include <benchmark/benchmark.h>
#include <lapacke.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/gipdyn.h"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/gp/cholesky.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/gp/lagrangian_weight_space_nll.hpp"
#include "gipdyn/gp/sparse_gp.hpp"
#include "gipdyn/gp/weight_space_nll.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace {

using namespace gipdyn;

struct Problem {
  JointTypes joints = JointTypes::parse("R");
  Eigen::MatrixXd X, Y, Z;
};

const Problem& problem(int robot, int N) {
  static std::map<std::pair<int, int>, Problem> cache;
  auto it = cache.find({robot, N});
  if (it != cache.end()) return it->second;
  const RobotModel model = robot == 4 ? scara_robot() : ur10_robot();
  SimulationOptions o;
  o.samples = N;
  o.seed = 11;
  const SimulationResult r = simulate(model, o);
  Problem p;
  p.joints = model.joint_types();
  p.X = r.X;
  p.Y = r.tau;
  p.Z = FeatureMap(p.joints).compute(p.X);
  return cache.emplace(std::make_pair(robot, N), p).first->second;
}

std::string label(int robot) { return robot == 4 ? "RRPR" : "RRRRRR"; }

// One joint's GIP GP on a problem: kernel at its data-driven start, standardised torques.
struct JointSetup {
  const Problem& p;
  std::unique_ptr<Kernel> kernel;
  double log_noise = std::log(1e-2);
  Eigen::VectorXd y;
};

JointSetup joint_setup(const benchmark::State& state, const std::string& kernel = "gip") {
  use_single_threaded_blas();
  JointSetup s{problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))), nullptr, std::log(1e-2), {}};
  s.kernel = make_kernel(kernel, FeatureMap(s.p.joints), 0);
  const Eigen::VectorXd t = s.p.Y.col(0);
  s.y = ((t.array() - t.mean()) / std::sqrt((t.array() - t.mean()).square().mean())).matrix();
  s.kernel->initialize(s.p.Z, 1.0);
  return s;
}

void BM_KernelBuild(benchmark::State& state) {
  JointSetup s = joint_setup(state);
  const Problem& p = s.p;
  Eigen::MatrixXd K(p.Z.rows(), p.Z.rows());
  KernelScratch scratch;
  for (auto _ : state) {
    s.kernel->gram_lower(p.Z, K, scratch);
    benchmark::DoNotOptimize(K.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " gip");
}

void time_nll_gradient(benchmark::State& state, const JointSetup& s, const std::string& what) {
  GpWorkspace ws;
  for (auto _ : state) {
    const NllEvaluation e = evaluate_nll(*s.kernel, s.log_noise, s.p.Z, s.y, true, ws);
    if (!e.ok()) state.SkipWithError(e.message.c_str());
    benchmark::DoNotOptimize(e.gradient.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " " + what);
}

void nll_gradient(benchmark::State& state, const std::string& kernel) {
  const JointSetup s = joint_setup(state, kernel);
  time_nll_gradient(state, s, kernel + ", " + std::to_string(s.kernel->num_params() + 1) + " params");
}


// The fused gradient pass alone (GipKernel::contract_nll): what an evaluation adds
// to the potrf + potri floor besides the kernel build and two triangular solves.
void BM_GradientContraction(benchmark::State& state) {
  JointSetup s = joint_setup(state);
  const Eigen::Index N = s.p.Z.rows();
  Eigen::MatrixXd Kinv(N, N);
  KernelScratch scratch;
  s.kernel->gram_lower(s.p.Z, Kinv, scratch);  // any lower triangle will do: only its values' cost matters
  const Eigen::VectorXd alpha = s.y;
  Eigen::VectorXd grad(s.kernel->num_params());
  for (auto _ : state) {
    grad.setZero();
    s.kernel->contract_nll(s.p.Z, alpha, Kinv, grad, scratch);
    benchmark::DoNotOptimize(grad.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " gip");
}

void BM_NllGradient(benchmark::State& state) { nll_gradient(state, "gip"); }
// The smooth friction term on top of GIP (SumKernel, FrictionKernel): what it adds to an evaluation.
void BM_NllGradientGipFriction(benchmark::State& state) { nll_gradient(state, "gip+friction"); }
// GIP times the RBF envelope (EnvelopeKernel): two kernel matrices and their product per evaluation.
void BM_NllGradientGipEnvelope(benchmark::State& state) { nll_gradient(state, "gip-envelope"); }
// The real preset's kernel: the envelope's product and the friction term share one W.
void BM_NllGradientGipEnvelopeFriction(benchmark::State& state) { nll_gradient(state, "gip-envelope+friction"); }

// W = alpha alpha^T - Kinv from Kinv's lower triangle (Kernel::nll_weights): what
// a sum saves per child without a fused contraction beyond the first, since its
// children share one W.
void BM_NllWeights(benchmark::State& state) {
  JointSetup s = joint_setup(state);
  const Eigen::Index N = s.p.Z.rows();
  Eigen::MatrixXd Kinv(N, N), W;
  KernelScratch scratch;
  s.kernel->gram_lower(s.p.Z, Kinv, scratch);
  for (auto _ : state) {
    Kernel::nll_weights(s.y, Kinv, W);
    benchmark::DoNotOptimize(W.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))));
}

// PP (a prior on the rigid-body parameters, rank 40 on the SCARA and 60 on the UR10): the exact
// NLL on the N x N matrix against the weight-space evaluation that training uses for it.
JointSetup pp_setup(const benchmark::State& state, const std::string& kernel = "pp") {
  JointSetup s = joint_setup(state);
  RobotPrior prior;
  prior.robot = std::make_shared<const RobotModel>(state.range(0) == 4 ? scara_robot() : ur10_robot());
  s.kernel = make_kernel(kernel, FeatureMap(s.p.joints), 0, prior);
  s.kernel->initialize(s.p.Z, 1.0);
  return s;
}

void BM_NllGradientPpExact(benchmark::State& state) { time_nll_gradient(state, pp_setup(state), "pp, N x N"); }

// SP (PP + RBF) as training evaluates it: both children contract one shared W.
void BM_NllGradientSp(benchmark::State& state) { time_nll_gradient(state, pp_setup(state, "sp"), "sp"); }

void BM_NllGradientPpWeightSpace(benchmark::State& state) {
  JointSetup s = pp_setup(state);
  Eigen::MatrixXd Phi;
  s.kernel->weight_space_features(s.p.Z, Phi);
  const WeightSpaceNll weight_space(Phi, s.y);
  const Eigen::VectorXd log_s = s.kernel->log_params();
  for (auto _ : state) {
    const NllEvaluation e = weight_space.evaluate(log_s, s.log_noise);
    if (!e.ok()) state.SkipWithError(e.message.c_str());
    benchmark::DoNotOptimize(e.gradient.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " pp, weight space, r = " +
                 std::to_string(Phi.cols()));
}

// One sparse (VFE) bound + gradient evaluation with M inducing rows (range 2)
// chosen by greedy variance: O(N M^2), against the exact GP's O(N^3).
void BM_VfeGradient(benchmark::State& state) {
  JointSetup s = joint_setup(state);
  const Problem& p = s.p;
  const Eigen::MatrixXd Zm = p.Z(select_inducing_rows(*s.kernel, p.Z, state.range(2)), Eigen::all);
  SparseGpWorkspace ws;
  for (auto _ : state) {
    const NllEvaluation e = evaluate_vfe(*s.kernel, s.log_noise, p.Z, s.y, Zm, true, ws);
    if (!e.ok()) state.SkipWithError(e.message.c_str());
    benchmark::DoNotOptimize(e.gradient.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " gip, M = " + std::to_string(Zm.rows()));
}

// The floor of BM_NllGradient: the factor and the inverse by the routines
// evaluate_nll calls, on the same threads (gp/cholesky.hpp: LAPACK on one
// thread below 1536 rows, tiles on every core from there), so that the ratio
// printed after the run is the evaluation's own overhead.
void BM_PotrfPotri(benchmark::State& state) {
  JointSetup s = joint_setup(state);
  const int N = static_cast<int>(state.range(1));
  Eigen::MatrixXd K0(N, N), K(N, N);
  KernelScratch scratch;
  s.kernel->gram_lower(s.p.Z, K0, scratch);
  K0.diagonal().array() += 1e-2;
  for (auto _ : state) {
    state.PauseTiming();
    K = K0;
    state.ResumeTiming();
    if (!cholesky_in_place(K) || !cholesky_inverse_in_place(K)) state.SkipWithError("not positive definite");
    benchmark::DoNotOptimize(K.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " floor");
}

// One Cholesky factorisation of a well-conditioned N x N matrix: LAPACK's
// potrf on one thread (threads 0 in the label's place: -1) against
// cholesky_in_place's tiles on 1 and 2 threads (gp/cholesky.hpp). The
// matrix is a random one, A A^T / N + I: the factorisation's cost does not
// depend on the kernel.
Eigen::MatrixXd random_covariance(int N) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd A(N, 256);
  for (Eigen::Index k = 0; k < A.size(); ++k) A.data()[k] = normal(rng);
  Eigen::MatrixXd K = A * A.transpose() / 256.0;
  K.diagonal().array() += 1.0;
  return K;
}

void BM_Cholesky(benchmark::State& state) {
  use_single_threaded_blas();
  const int N = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  const Eigen::MatrixXd K0 = random_covariance(N);
  Eigen::MatrixXd K;
  for (auto _ : state) {
    state.PauseTiming();
    K = K0;
    state.ResumeTiming();
    const bool ok = threads < 0 ? LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', N, K.data(), N) == 0
                                : cholesky_in_place(K, threads);
    if (!ok) state.SkipWithError("not positive definite");
    benchmark::DoNotOptimize(K.data());
  }
  state.SetLabel(threads < 0 ? "LAPACK potrf" : "tiles on " + std::to_string(threads) + " thread(s)");
}

// The inverse from the factor, (L L^T)^{-1}: LAPACK's potri (threads -1) or
// cholesky_inverse_in_place's tiles on 1 and 2 threads.
void BM_CholeskyInverse(benchmark::State& state) {
  use_single_threaded_blas();
  const int N = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  Eigen::MatrixXd L0 = random_covariance(N), L;
  if (!cholesky_in_place(L0, 1)) state.SkipWithError("not positive definite");
  for (auto _ : state) {
    state.PauseTiming();
    L = L0;
    state.ResumeTiming();
    const bool ok = threads < 0 ? LAPACKE_dpotri_work(LAPACK_COL_MAJOR, 'L', N, L.data(), N) == 0
                                : cholesky_inverse_in_place(L, threads);
    if (!ok) state.SkipWithError("singular");
    benchmark::DoNotOptimize(L.data());
  }
  state.SetLabel(threads < 0 ? "LAPACK potri" : "tiles on " + std::to_string(threads) + " thread(s)");
}

const InverseDynamicsModel& quick_model(int robot, int N, const std::string& kernel = "gip") {
  static std::map<std::tuple<int, int, std::string>, InverseDynamicsModel> cache;
  auto it = cache.find({robot, N, kernel});
  if (it != cache.end()) return it->second;
  const Problem& p = problem(robot, N);
  TrainOptions o;
  o.kernel = kernel;
  o.search.optimizer.max_iterations = 3;  // latency does not depend on the hyperparameter values
  TrainResult r = train_model(p.X, p.Y, p.joints, o);
  return cache.emplace(std::make_tuple(robot, N, kernel), std::move(r.model)).first->second;
}

void predict_one_mean(benchmark::State& state, const std::string& kernel) {
  use_single_threaded_blas();
  const InverseDynamicsModel& m = quick_model(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), kernel);
  PredictionWorkspace ws(m);
  const Problem& p = problem(static_cast<int>(state.range(0)), 1000);
  Eigen::VectorXd x = p.X.row(17).transpose(), tau(m.num_joints());
  for (auto _ : state) {
    ws.predict(x.data(), tau.data());
    benchmark::DoNotOptimize(tau.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " all joints, mean" + (kernel == "gip" ? "" : ", " + kernel));
}

void BM_PredictOneMean(benchmark::State& state) { predict_one_mean(state, "gip"); }
// The real preset's kernel (gip-envelope+friction) goes through the composite
// kernels' rows, not GIP's fused all-joints pass.
void BM_PredictOneMeanPresetReal(benchmark::State& state) { predict_one_mean(state, "gip-envelope+friction"); }

void BM_PredictOneMeanVariance(benchmark::State& state) {
  use_single_threaded_blas();
  const InverseDynamicsModel m =
      quick_model(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))).with_variance();
  PredictionWorkspace ws(m);
  const Problem& p = problem(static_cast<int>(state.range(0)), 1000);
  Eigen::VectorXd x = p.X.row(17).transpose(), tau(m.num_joints()), sd(m.num_joints());
  for (auto _ : state) {
    ws.predict(x.data(), tau.data(), sd.data());
    benchmark::DoNotOptimize(sd.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " all joints, mean + variance");
}

// The same query through the C API (load from a file, C workspace): its
// overhead over the C++ path is the argument checks and the input copy.
void BM_PredictOneMeanCApi(benchmark::State& state) {
  use_single_threaded_blas();
  const InverseDynamicsModel& m = quick_model(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const std::string path = (std::filesystem::temp_directory_path() / "gipdyn_bench_c_api.gipdyn").string();
  save_model(m, path);
  gipdyn_model* model = nullptr;
  gipdyn_workspace* ws = nullptr;
  if (gipdyn_model_load(path.c_str(), &model) != GIPDYN_OK || gipdyn_workspace_create(model, &ws) != GIPDYN_OK) {
    state.SkipWithError(gipdyn_last_error());
    return;
  }
  std::filesystem::remove(path);
  const int n = m.num_joints();
  const Problem& p = problem(static_cast<int>(state.range(0)), 1000);
  Eigen::VectorXd x = p.X.row(17).transpose(), tau(n);
  for (auto _ : state) {
    gipdyn_predict(ws, x.data(), x.data() + n, x.data() + 2 * n, n, tau.data());
    benchmark::DoNotOptimize(tau.data());
  }
  gipdyn_workspace_free(ws);
  gipdyn_model_free(model);
  state.SetLabel(label(static_cast<int>(state.range(0))) + " all joints, mean, C API");
}

// Online learning: a stream of samples into a model whose factors exist, as
// a sliding window (one in, the oldest out), reusing the factors
// (std::move(model).updated).
void BM_UpdateOneSample(benchmark::State& state) {
  use_single_threaded_blas();
  InverseDynamicsModel m =
      quick_model(static_cast<int>(state.range(0)), static_cast<int>(state.range(1))).with_variance();
  const Problem& p = problem(static_cast<int>(state.range(0)), 1000);
  const Eigen::Index window = m.num_training_samples();
  Eigen::Index row = 0;
  for (auto _ : state) {
    m = std::move(m).updated(p.X.row(row), p.Y.row(row), window);
    row = (row + 1) % p.X.rows();
    benchmark::DoNotOptimize(m.joint_gp(0).alpha().data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " all joints, one sample in, the oldest out");
}

// Online learning of a sparse model (N training rows, M inducing rows): one
// sample in, nothing out; the cost is O(M^2) per joint, independent of N.
void BM_AddOneSampleSparse(benchmark::State& state) {
  use_single_threaded_blas();
  const int robot = static_cast<int>(state.range(0)), N = static_cast<int>(state.range(1));
  const Problem& p = problem(robot, N);
  TrainOptions o;
  o.sparse.inducing_points = static_cast<int>(state.range(2));
  o.search.optimizer.max_iterations = 3;  // the cost does not depend on the hyperparameter values
  InverseDynamicsModel m = train_model(p.X, p.Y, p.joints, o).model.with_variance();
  const Problem& stream = problem(robot, 1000);
  Eigen::Index row = 0;
  for (auto _ : state) {
    m = std::move(m).updated(stream.X.row(row), stream.Y.row(row));
    row = (row + 1) % stream.X.rows();
    benchmark::DoNotOptimize(m.joint_gp(0).alpha().data());
  }
  state.SetLabel(label(robot) + " all joints, sparse, one sample in");
}

void BM_Train(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  int evaluations = 0;
  std::vector<int> per_joint(p.joints.size(), 0);
  for (auto _ : state) {
    TrainOptions o;  // the defaults: gip, L-BFGS to convergence, joints in parallel
    o.gp.keep_factor = false;
    const TrainResult r = train_model(p.X, p.Y, p.joints, o);
    if (!r.report.ok()) state.SkipWithError(r.report.message.c_str());
    for (std::size_t j = 0; j < r.report.joints.size() && j < per_joint.size(); ++j) {
      evaluations += r.report.joints[j].evaluations;
      per_joint[j] += r.report.joints[j].evaluations;
    }
  }
  state.counters["nll_evals"] = evaluations;
  for (std::size_t j = 0; j < per_joint.size(); ++j) state.counters["evals_j" + std::to_string(j + 1)] = per_joint[j];
  state.SetLabel(label(static_cast<int>(state.range(0))) + " gip, default options, all joints");
}

// LIP (docs/method.md section 11): the (N n) x (N n) torque covariance and the
// gradient contraction of one NLL evaluation, at its data-driven start. The
// factorisation is LAPACK's, as BM_PotrfPotri at N n.
LagrangianKernel lip_kernel(const Problem& p, bool serial_chain = false) {
  LagrangianKernel k(p.joints, false, serial_chain);
  k.initialize(p.X, 1.0);
  return k;
}

void BM_LipGram(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const LagrangianKernel k = lip_kernel(p, state.range(2) != 0);
  Eigen::MatrixXd K;
  for (auto _ : state) {
    k.torque_gram_lower(p.X, K);
    benchmark::DoNotOptimize(K.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " system " + std::to_string(K.rows()) +
                 (k.serial_chain() ? " serial chain" : ""));
}

void BM_LipGradient(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const LagrangianKernel k = lip_kernel(p, state.range(2) != 0);
  const Eigen::Index m = p.X.rows() * p.joints.size();
  const Eigen::MatrixXd W = Eigen::MatrixXd::Constant(m, m, 1e-3);
  Eigen::VectorXd grad(k.num_params());
  for (auto _ : state) {
    grad.setZero();
    k.add_gradient(p.X, W, grad);
    benchmark::DoNotOptimize(grad.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " " + std::to_string(k.num_params()) + " parameters" +
                 (k.serial_chain() ? ", serial chain" : ""));
}

// One NLL + gradient evaluation of LIP in weight space (the serial chain with
// friction, as the estimators fit it), where LagrangianWeightSpaceNll::worthwhile
// chooses it: the SCARA. Its kernel-space counterpart is BM_LipGram plus
// BM_LipGradient plus potrf and potri of the (N n)^2 system.
void BM_LipWeightSpaceNll(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const int n = p.joints.size();
  LagrangianKernel k(p.joints, true, true);
  k.initialize(p.X, 1.0);
  Eigen::VectorXd y(p.X.rows() * n);
  for (Eigen::Index r = 0; r < p.X.rows(); ++r)
    for (int i = 0; i < n; ++i) y(r * n + i) = p.Y(r, i);
  y /= std::sqrt(y.squaredNorm() / static_cast<double>(y.size()));
  const LagrangianWeightSpaceNll nll(k, p.X, y);
  const Eigen::VectorXd noise = Eigen::VectorXd::Constant(n, 1e-3);
  for (auto _ : state) {
    const NllEvaluation e = nll.evaluate(k, noise, true);
    benchmark::DoNotOptimize(e.gradient.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " " + std::to_string(nll.features()) + " features" +
                 (LagrangianWeightSpaceNll::worthwhile(k, p.X.rows()) ? ", chosen" : ""));
}

// One query's torques from a LIP model on N rows (weights arbitrary: the cost does not depend on them).
void BM_LipPredictOne(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const int n = p.joints.size();
  const LagrangianEstimator model(lip_kernel(p), Eigen::VectorXd::Ones(n), 1.0, p.X,
                                  Eigen::VectorXd::Constant(p.X.rows() * n, 1e-3));
  const Eigen::MatrixXd x = p.X.row(0);
  for (auto _ : state) benchmark::DoNotOptimize(model.predict(x).data());
  state.SetLabel(label(static_cast<int>(state.range(0))) + " all joints");
}

// One query's torques both ways, whichever LagrangianEstimator would choose:
// the weight-space polynomials (LagrangianWeightSpaceMean, built once) and the
// kernel-space sum of one n x n block per training row.
void BM_LipQueryWeightSpace(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const int n = p.joints.size();
  const LagrangianKernel k = lip_kernel(p, state.range(2) != 0);
  const LagrangianWeightSpaceMean mean(k, p.X, Eigen::VectorXd::Constant(p.X.rows() * n, 1e-3));
  LagrangianWeightSpaceMean::Workspace w(mean);
  // A new q every query, as in a control loop (a query at the previous q reuses its functions of q).
  const Eigen::MatrixXd states = p.X.topRows(std::min<Eigen::Index>(p.X.rows(), 64)).transpose();
  Eigen::VectorXd tau(n);
  Eigen::Index r = 0;
  for (auto _ : state) {
    mean.mean(states.col(r).data(), w, tau.data());
    benchmark::DoNotOptimize(tau.data());
    r = (r + 1) % states.cols();
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) + " " +
                 std::to_string(static_cast<long>(LagrangianWeightSpaceMean::kinetic_basis_size(p.joints))) +
                 " basis products per coefficient" +
                 (LagrangianWeightSpaceMean::worthwhile(k, p.X.rows()) ? ", chosen" : "") +
                 (state.range(2) != 0 ? ", serial chain" : ""));
}

void BM_LipQueryKernelSpace(benchmark::State& state) {
  const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const int n = p.joints.size();
  const LagrangianKernel k = lip_kernel(p, state.range(2) != 0);
  LagrangianKernel::PairScratch scratch(k);
  const Eigen::MatrixXd states = p.X.transpose();
  const Eigen::VectorXd alpha = Eigen::VectorXd::Constant(p.X.rows() * n, 1e-3);
  Eigen::MatrixXd block(n, n);
  Eigen::VectorXd tau(n);
  for (auto _ : state) {
    tau.setZero();
    for (Eigen::Index r = 0; r < states.cols(); ++r) {
      k.torque_block(states.col(0).data(), states.col(r).data(), scratch, block);
      tau.noalias() += block * alpha.segment(r * n, n);
    }
    benchmark::DoNotOptimize(tau.data());
  }
  state.SetLabel(label(static_cast<int>(state.range(0))) +
                 (LagrangianWeightSpaceMean::worthwhile(k, p.X.rows()) ? "" : ", chosen") +
                 (state.range(2) != 0 ? ", serial chain" : ""));
}

// Kernel space: the third argument is 1 for the serial-chain kernel.
void lip_query_sizes(benchmark::internal::Benchmark* b) {
  for (int robot : {4, 6})
    for (int N : {50, 150, 600, 2000})
      for (int chain : {0, 1}) b->Args({robot, N, chain});
  b->Unit(benchmark::kMicrosecond);
}

// Weight space: the third argument is 1 for the serial-chain kernel.
void lip_query_chain_sizes(benchmark::internal::Benchmark* b) {
  for (int robot : {4, 6})
    for (int chain : {0, 1}) b->Args({robot, 2000, chain});
  b->Unit(benchmark::kMicrosecond);
}

void lip_sizes(benchmark::internal::Benchmark* b) {
  for (int robot : {4, 6})
    for (int N : {150, 300, 600}) b->Args({robot, N});
  b->Unit(benchmark::kMillisecond);
}

// The same with the third argument: 1 for the serial-chain kernel.
void lip_chain_sizes(benchmark::internal::Benchmark* b) {
  for (int robot : {4, 6})
    for (int chain : {0, 1}) b->Args({robot, 300, chain});
  b->Unit(benchmark::kMillisecond);
}

void sizes(benchmark::internal::Benchmark* b) {
  for (int robot : {4, 6})
    for (int N : {1000, 2000, 4000}) b->Args({robot, N});
  b->Unit(benchmark::kMillisecond);
}

void sparse_sizes(benchmark::internal::Benchmark* b) {
  for (int robot : {4, 6})
    for (int N : {2000, 20000, 100000})
      for (int M : {100, 300, 1000}) b->Args({robot, N, M});
  b->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_KernelBuild)->Apply(sizes);
BENCHMARK(BM_VfeGradient)->Apply(sparse_sizes);
BENCHMARK(BM_NllGradient)->Apply(sizes);
BENCHMARK(BM_GradientContraction)->Apply(sizes);
BENCHMARK(BM_NllGradientGipFriction)->Apply(sizes);
BENCHMARK(BM_NllGradientGipEnvelope)->Apply(sizes);
BENCHMARK(BM_NllGradientGipEnvelopeFriction)->Apply(sizes);
BENCHMARK(BM_NllWeights)->Apply(sizes);
BENCHMARK(BM_PotrfPotri)->Apply(sizes);
BENCHMARK(BM_Cholesky)
    ->ArgsProduct({{1024, 1800, 2048, 4096, 8192, 12000}, {-1, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK(BM_CholeskyInverse)
    ->ArgsProduct({{1024, 1800, 2048, 4096, 8192}, {-1, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK(BM_NllGradientPpExact)->Apply(sizes);
BENCHMARK(BM_NllGradientSp)->Apply(sizes);
BENCHMARK(BM_NllGradientPpWeightSpace)->Apply(sizes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PredictOneMean)->Apply(sizes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PredictOneMeanPresetReal)->Apply(sizes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PredictOneMeanVariance)->Apply(sizes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PredictOneMeanCApi)->Apply(sizes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_UpdateOneSample)->Apply(sizes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AddOneSampleSparse)
    ->ArgsProduct({{4, 6}, {4000}, {100, 300, 1000}})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LipGram)->Apply(lip_chain_sizes);
BENCHMARK(BM_LipGradient)->Apply(lip_chain_sizes);
BENCHMARK(BM_LipWeightSpaceNll)->Args({4, 150})->Args({4, 300})->Args({4, 600})->Args({4, 2000})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LipPredictOne)->Apply(lip_sizes)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LipQueryWeightSpace)->Apply(lip_query_chain_sizes);
BENCHMARK(BM_LipQueryKernelSpace)->Apply(lip_query_sizes);
BENCHMARK(BM_Train)->Apply(sizes)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

// Collects per-case times to print the NLL-gradient / potrf+potri ratio.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      const std::string name = r.benchmark_name();
      times_[name] = r.GetAdjustedRealTime();
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::printf("\nNLL + gradient / (potrf + potri), same N, the same factorisation routines and threads:\n");
    for (int robot : {4, 6})
      for (int N : {1000, 2000, 4000}) {
        const std::string args = "/" + std::to_string(robot) + "/" + std::to_string(N);
        auto a = times_.find("BM_NllGradient" + args), b = times_.find("BM_PotrfPotri" + args);
        if (a == times_.end() || b == times_.end()) continue;
        std::printf("  %-7s N=%-5d  nll+grad %8.1f ms  floor %8.1f ms  ratio %.2f\n", label(robot).c_str(), N,
                    a->second, b->second, a->second / b->second);
      }
  }

 private:
  std::map<std::string, double> times_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
