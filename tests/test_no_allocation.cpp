// The control-loop promise: after a PredictionWorkspace is built, single-query
// prediction makes no heap allocation. This binary interposes malloc and
// friends (glibc's __libc_* entry points) and counts calls while armed.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include <unistd.h>

#include <filesystem>

#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/estimators/neural_network_estimator.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/gipdyn.h"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/model/training.hpp"
#include "test_util.hpp"

extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
void __libc_free(void*);
}

namespace {
std::atomic<bool> g_armed{false};
std::atomic<long> g_allocations{0};
// Allocations of g_matrix_bytes plus at most an alignment's padding (Eigen's
// N x N matrices), counted while armed. OpenBLAS allocates its own buffers,
// of other sizes, in every call.
std::atomic<size_t> g_matrix_bytes{0};
std::atomic<long> g_matrix_allocations{0};
void note(size_t bytes) {
  if (!g_armed.load(std::memory_order_relaxed)) return;
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const size_t matrix = g_matrix_bytes.load(std::memory_order_relaxed);
  if (bytes >= matrix && bytes <= matrix + 128) g_matrix_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(size_t n) {
  note(n);
  return __libc_malloc(n);
}
void* calloc(size_t a, size_t b) {
  note(a * b);
  return __libc_calloc(a, b);
}
void* realloc(void* p, size_t n) {
  note(n);
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
int posix_memalign(void** out, size_t align, size_t n) {
  note(n);
  *out = __libc_memalign(align, n);
  return *out ? 0 : 12;
}
void* aligned_alloc(size_t align, size_t n) {
  note(n);
  return __libc_memalign(align, n);
}
void* memalign(size_t align, size_t n) {
  note(n);
  return __libc_memalign(align, n);
}
}

namespace gipdyn {
namespace {

// Saves `estimator`, loads it through the C API (null on failure, with the
// failure recorded) and removes the file.
gipdyn_model* load_through_c_api(const Estimator& estimator, const std::string& name) {
  const std::string path =
      (std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()) + ".gipdyn")).string();
  save_estimator(estimator, path);
  gipdyn_model* model = nullptr;
  const gipdyn_status status = gipdyn_model_load(path.c_str(), &model);
  std::filesystem::remove(path);
  EXPECT_EQ(status, GIPDYN_OK) << gipdyn_last_error();
  return model;
}

// Heap allocations made while `body` runs.
template <class Body>
long allocations_during(Body&& body) {
  g_allocations = 0;
  g_armed = true;
  body();
  g_armed = false;
  return g_allocations.load();
}

TEST(NoAllocation, InterpositionSeesAllocations) {
  static void* volatile sink_c;  // volatile: the compiler may not elide the pairs
  static double* volatile sink_cpp;
  g_allocations = 0;
  g_armed = true;
  sink_c = std::malloc(64);
  sink_cpp = new double[8];
  g_armed = false;
  std::free(sink_c);
  delete[] sink_cpp;
  EXPECT_GE(g_allocations.load(), 2);  // the counter works, so a zero below means something
}

TEST(NoAllocation, SingleQueryPredictionDoesNotAllocate) {
  for (const char* kernel : {"gip", "gip-friction", "rbf", "gip-envelope+friction", "gip+friction+rbf"}) {
    const JointTypes joints = JointTypes::parse("RRPR");
    const Eigen::MatrixXd X = test::random_inputs(joints, 80, 61);
    const Eigen::MatrixXd Y = test::random_matrix(80, 4, -1.0, 1.0, 912);
    TrainOptions o;
    o.kernel = kernel;
    o.search.optimizer.max_iterations = 5;
    TrainResult r = train_model(X, Y, joints, o);
    ASSERT_TRUE(r.report.ok()) << r.report.message;
    PredictionWorkspace ws(r.model);
    const Eigen::MatrixXd Xq = test::random_inputs(joints, 10, 62);
    Eigen::VectorXd x(12), tau(4), sd(4), M(16);
    ws.predict(Xq.row(0).transpose().eval().data(), tau.data(), sd.data());  // warm-up of the variance path
    EXPECT_EQ(allocations_during([&] {
                for (int k = 0; k < 10; ++k) {
                  for (int c = 0; c < 12; ++c) x(c) = Xq(k, c);
                  ws.predict(x.data(), tau.data());
                  ws.predict(x.data(), tau.data(), sd.data());
                  ws.rigid_body_terms(x.data(), x.data() + 4, tau.data(), M.data(), sd.data());
                }
              }),
              0)
        << kernel;
  }
}

// pp and sp fold alpha into the regressor's weights (ParametricKernel::
// plan_mean): a query evaluates one regressor, not one per training row (50 ms
// a query on 2000 UR10 rows before), allocates nothing, and answers as the
// batch prediction does.
TEST(NoAllocation, ModelBasedKernelQueriesUseOneRegressorAndDoNotAllocate) {
  for (const char* kernel : {"pp", "sp"}) {
    const JointTypes joints = JointTypes::parse("RRPR");
    const Eigen::MatrixXd X = test::random_inputs(joints, 60, 63);
    const Eigen::MatrixXd Y = test::random_matrix(60, 4, -1.0, 1.0, 913);
    TrainOptions o;
    o.kernel = kernel;
    o.robot_prior.robot = std::make_shared<const RobotModel>(load_robot("scara"));
    o.search.optimizer.max_iterations = 5;
    TrainResult r = train_model(X, Y, joints, o);
    ASSERT_TRUE(r.report.ok()) << r.report.message;
    PredictionWorkspace ws(r.model);
    const Eigen::MatrixXd Xq = test::random_inputs(joints, 10, 64);
    const Eigen::MatrixXd batch = r.model.predict(Xq);
    Eigen::VectorXd x(12), tau(4);
    Eigen::MatrixXd single(10, 4);
    EXPECT_EQ(allocations_during([&] {
                for (int k = 0; k < 10; ++k) {
                  for (int c = 0; c < 12; ++c) x(c) = Xq(k, c);
                  ws.predict(x.data(), tau.data());
                  for (int j = 0; j < 4; ++j) single(k, j) = tau(j);
                }
              }),
              0)
        << kernel;
    EXPECT_LT((single - batch).cwiseAbs().maxCoeff(), 1e-10 * (1.0 + batch.cwiseAbs().maxCoeff())) << kernel;
    // The standard deviation of one query (k(z, Z) from the regressor of Z the
    // scratch keeps, k(z, z) from the query's) answers as the batch's, and
    // allocates nothing once the first query has computed the regressor of Z.
    const InverseDynamicsModel with_variance = r.model.with_variance();
    Eigen::MatrixXd mean, stddev;
    with_variance.predict(Xq, mean, &stddev);
    PredictionWorkspace variance_ws(with_variance);
    Eigen::VectorXd sd(4);
    Eigen::MatrixXd single_sd(10, 4);
    variance_ws.predict(Xq.row(9).transpose().eval().data(), tau.data(), sd.data());  // warm-up
    EXPECT_EQ(allocations_during([&] {
                for (int k = 0; k < 10; ++k) {
                  for (int c = 0; c < 12; ++c) x(c) = Xq(k, c);
                  variance_ws.predict(x.data(), tau.data(), sd.data());
                  for (int j = 0; j < 4; ++j) {
                    single(k, j) = tau(j);
                    single_sd(k, j) = sd(j);
                  }
                }
              }),
              0)
        << kernel << " with standard deviations";
    for (int k = 0; k < 10; ++k)
      for (int j = 0; j < 4; ++j) {
        EXPECT_NEAR(single(k, j), mean(k, j), 1e-10 * (1.0 + std::abs(mean(k, j)))) << kernel;
        EXPECT_NEAR(single_sd(k, j), stddev(k, j), 1e-6 * stddev(k, j) + 1e-12) << kernel << " joint " << j + 1;
      }
  }
}

// The C API's promise for a control loop: torque, gravity, inertia and
// forward dynamics (and their error paths) allocate nothing once the workspace exists.
TEST(NoAllocation, CApiQueriesDoNotAllocate) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 80, 63);
  TrainOptions o;
  o.search.optimizer.max_iterations = 5;
  TrainResult r = train_model(X, test::random_matrix(80, 4, -1.0, 1.0, 913), joints, o);
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  const std::string path =
      (std::filesystem::temp_directory_path() / ("gipdyn_c_api_" + std::to_string(::getpid()) + ".gipdyn")).string();
  save_model(r.model, path);
  gipdyn_model* model = nullptr;
  ASSERT_EQ(gipdyn_model_load(path.c_str(), &model), GIPDYN_OK) << gipdyn_last_error();
  std::filesystem::remove(path);
  gipdyn_workspace* ws = nullptr;
  ASSERT_EQ(gipdyn_workspace_create(model, &ws), GIPDYN_OK);
  double q[4] = {0.1, -0.2, 0.1, 0.3}, qd[4] = {0.5, 0.1, 0.0, -0.2}, qdd[4] = {1, 2, 0.1, -1}, tau[4], M[16];
  double nan_q[4] = {0.1, std::nan(""), 0.1, 0.3};
  ASSERT_EQ(gipdyn_inertia(ws, q, 4, M), GIPDYN_OK);  // warm-up (first use of the thread's message buffer)
  gipdyn_status statuses[10][6];
  EXPECT_EQ(allocations_during([&] {
              for (auto& s : statuses) {
                s[0] = gipdyn_predict(ws, q, qd, qdd, 4, tau);
                s[1] = gipdyn_gravity(ws, q, 4, tau);
                s[2] = gipdyn_inertia(ws, q, 4, M);
                s[3] = gipdyn_predict(ws, nan_q, qd, qdd, 4, tau);
                s[4] = gipdyn_predict(ws, q, qd, qdd, 3, tau);
                s[5] = gipdyn_forward_dynamics(ws, q, qd, tau, 4, M);
              }
            }),
            0);
  for (const auto& s : statuses) {
    EXPECT_EQ(s[0], GIPDYN_OK);
    EXPECT_EQ(s[1], GIPDYN_OK);
    EXPECT_EQ(s[2], GIPDYN_OK);
    EXPECT_EQ(s[3], GIPDYN_ERROR_NOT_FINITE);
    EXPECT_EQ(s[4], GIPDYN_ERROR_SIZE);
    EXPECT_TRUE(s[5] == GIPDYN_OK || s[5] == GIPDYN_ERROR_SINGULAR) << gipdyn_status_string(s[5]);
  }
  gipdyn_workspace_free(ws);
  gipdyn_model_free(model);
}

// A network's C API queries allocate nothing either (two layer buffers in the workspace).
// A contact detector's step, both methods, over a loaded GIP model with its learned noise.
TEST(NoAllocation, CApiContactDetectorStepsDoNotAllocate) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 80, 64);
  TrainOptions o;
  o.search.optimizer.max_iterations = 5;
  TrainResult r = train_model(X, test::random_matrix(80, 4, -1.0, 1.0, 914), joints, o);
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  const std::string path =
      (std::filesystem::temp_directory_path() / ("gipdyn_c_contacts_" + std::to_string(::getpid()) + ".gipdyn")).string();
  save_model(r.model, path);
  gipdyn_model* model = nullptr;
  ASSERT_EQ(gipdyn_model_load(path.c_str(), &model), GIPDYN_OK) << gipdyn_last_error();
  std::filesystem::remove(path);
  for (gipdyn_contact_method method : {GIPDYN_CONTACT_RESIDUAL, GIPDYN_CONTACT_MOMENTUM}) {
    gipdyn_contact_options options = gipdyn_contact_options_default();
    options.method = method;
    options.sample_time = 0.001;
    gipdyn_contact_detector* detector = nullptr;
    ASSERT_EQ(gipdyn_contact_detector_create(model, &options, nullptr, 4, &detector), GIPDYN_OK) << gipdyn_last_error();
    double q[4] = {0.1, -0.2, 0.1, 0.3}, qd[4] = {0.5, 0.1, 0.0, -0.2}, qdd[4] = {1, 2, 0.1, -1}, tau[4] = {1, 2, 3, 4};
    double ext[4], margin[4];
    int contact[4];
    ASSERT_EQ(gipdyn_contact_detector_step(detector, q, qd, qdd, tau, 4, ext, contact, margin), GIPDYN_OK);  // warm-up
    gipdyn_status statuses[20];
    EXPECT_EQ(allocations_during([&] {
                for (int k = 0; k < 20; ++k) {
                  q[0] += 1e-3;
                  statuses[k] = gipdyn_contact_detector_step(detector, q, qd, qdd, tau, 4, ext, contact, margin);
                }
              }),
              0);
    for (auto s : statuses) EXPECT_EQ(s, GIPDYN_OK);
    gipdyn_contact_detector_free(detector);
  }
  gipdyn_model_free(model);
}

TEST(NoAllocation, CApiNetworkQueriesDoNotAllocate) {
  if (!neural_network_training_available()) GTEST_SKIP() << "built without libtorch: no network to train";
  const JointTypes joints = JointTypes::parse("RRPR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 200, 64);
  NeuralNetworkOptions o;
  o.epochs = 2;
  o.hidden = {32, 16};
  const NeuralNetworkEstimator net(NeuralNetwork::train(X, test::random_matrix(200, 4, -1.0, 1.0, 914), joints, o));
  gipdyn_model* model = load_through_c_api(net, "gipdyn_c_api_nn");
  ASSERT_NE(model, nullptr);
  ASSERT_EQ(gipdyn_model_allocation_free(model), 1);
  gipdyn_workspace* ws = nullptr;
  ASSERT_EQ(gipdyn_workspace_create(model, &ws), GIPDYN_OK);
  double q[4] = {0.1, -0.2, 0.1, 0.3}, qd[4] = {0.5, 0.1, 0.0, -0.2}, qdd[4] = {1, 2, 0.1, -1}, tau[4];
  ASSERT_EQ(gipdyn_predict(ws, q, qd, qdd, 4, tau), GIPDYN_OK);  // warm-up
  const Eigen::MatrixXd expected = net.predict(X.topRows(1));
  gipdyn_status statuses[10];
  double first[4] = {0, 0, 0, 0};
  EXPECT_EQ(allocations_during([&] {
              for (auto& s : statuses) s = gipdyn_predict(ws, q, qd, qdd, 4, tau);
            }),
            0);
  for (auto s : statuses) EXPECT_EQ(s, GIPDYN_OK);
  // The same torques as the batch path.
  const Eigen::RowVectorXd x = X.row(0);
  ASSERT_EQ(gipdyn_predict(ws, x.data(), x.data() + 4, x.data() + 8, 4, first), GIPDYN_OK);
  for (int j = 0; j < 4; ++j) EXPECT_NEAR(first[j], expected(0, j), 1e-12 * (1 + std::abs(expected(0, j))));
  gipdyn_workspace_free(ws);
  gipdyn_model_free(model);
}

// Loads `estimator` through the C API and checks that its torque, gravity and
// inertia queries make no heap allocation.
void expect_queries_do_not_allocate(const Estimator& estimator, const std::string& name) {
  gipdyn_model* model = load_through_c_api(estimator, name);
  ASSERT_NE(model, nullptr);
  ASSERT_EQ(gipdyn_model_allocation_free(model), 1);
  gipdyn_workspace* ws = nullptr;
  ASSERT_EQ(gipdyn_workspace_create(model, &ws), GIPDYN_OK);
  const int n = estimator.joints().size();
  std::vector<double> q(static_cast<size_t>(n)), qd(q), qdd(q), tau(q), M(static_cast<size_t>(n * n));
  for (int i = 0; i < n; ++i) {
    q[static_cast<size_t>(i)] = 0.1 * (i % 3) - 0.2;
    qd[static_cast<size_t>(i)] = 0.5 - 0.3 * i;
    qdd[static_cast<size_t>(i)] = 1.0 - 0.7 * i;
  }
  ASSERT_EQ(gipdyn_inertia(ws, q.data(), n, M.data()), GIPDYN_OK);  // warm-up
  gipdyn_status statuses[10][3];
  EXPECT_EQ(allocations_during([&] {
              for (auto& s : statuses) {
                s[0] = gipdyn_predict(ws, q.data(), qd.data(), qdd.data(), n, tau.data());
                s[1] = gipdyn_gravity(ws, q.data(), n, tau.data());
                s[2] = gipdyn_inertia(ws, q.data(), n, M.data());
              }
            }),
            0);
  for (const auto& s : statuses)
    for (auto status : s) EXPECT_EQ(status, GIPDYN_OK) << gipdyn_status_string(status);
  gipdyn_workspace_free(ws);
  gipdyn_model_free(model);
}

// lip and fe C API queries allocate nothing either: LIP's n x n blocks and
// fe's regressor are built in the workspace. Torque, gravity and inertia alike.
// LIP answers in weight space on the SCARA and in kernel space on a 6R arm
// with few rows (LagrangianWeightSpaceMean::worthwhile): both are checked.
TEST(NoAllocation, CApiLagrangianAndFisherianQueriesDoNotAllocate) {
  for (const auto& [name, spec] : {std::pair<std::string, std::string>{"lip", "RRPR"}, {"lip", "RRRRRR"}, {"fe", "RRPR"}}) {
    SCOPED_TRACE(name + " " + spec);
    const JointTypes joints = JointTypes::parse(spec);
    const int rows = spec == "RRPR" ? 40 : 12;
    const Eigen::MatrixXd X = test::random_inputs(joints, rows, 65);
    EstimatorOptions o;
    o.name = name;
    o.search.optimizer.max_iterations = 5;
    o.robot_prior.robot = std::make_shared<const RobotModel>(load_robot("scara"));
    const FitResult fitted =
        fit_estimator(o, X, test::random_matrix(rows, joints.size(), -1.0, 1.0, 915), joints);
    ASSERT_TRUE(fitted.report.ok()) << fitted.report.message;
    if (name == "lip") {
      EXPECT_EQ(dynamic_cast<const LagrangianEstimator&>(*fitted.estimator).queries_in_weight_space(), spec == "RRPR");
    }
    expect_queries_do_not_allocate(*fitted.estimator, "gipdyn_c_api_" + name + spec);
  }
}

// An optimiser evaluates the NLL and its gradient hundreds of times on the same
// rows: after the first evaluation, the workspace's buffers must serve every
// N x N matrix. A composite kernel whose children resized a shared buffer
// between N x N and N x F, or allocated its children's matrices, paged in
// fresh N x N blocks at every evaluation (SP's fits took 1.6x as long).
TEST(NoAllocation, RepeatedNllEvaluationsAllocateNoKernelSizedMatrix) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const FeatureMap features(joints);
  const Eigen::Index n = 120;
  const Eigen::MatrixXd Z = features.compute(test::random_inputs(joints, n, 71));
  const Eigen::VectorXd y = test::random_matrix(n, 1, -1.0, 1.0, 72).col(0);
  RobotPrior prior;
  prior.robot = std::make_shared<const RobotModel>(load_robot("scara"));
  for (const char* name : {"gip", "rbf", "sp", "gip+rbf", "gip+friction", "gip+friction+rbf", "gip-envelope",
                           "gip-envelope+friction"}) {
    const std::unique_ptr<Kernel> kernel = make_kernel(name, features, 1, prior);
    kernel->initialize(Z, 1.0);
    GpWorkspace ws;
    ASSERT_TRUE(evaluate_nll(*kernel, std::log(0.1), Z, y, true, ws).ok()) << name;
    g_matrix_bytes = static_cast<size_t>(n * n) * sizeof(double);
    g_matrix_allocations = 0;
    allocations_during([&] {
      for (int e = 0; e < 3; ++e) evaluate_nll(*kernel, std::log(0.1 + 0.01 * e), Z, y, true, ws);
    });
    g_matrix_bytes = 0;
    EXPECT_EQ(g_matrix_allocations.load(), 0) << name;
  }
}

}  // namespace
}  // namespace gipdyn
