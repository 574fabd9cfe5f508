// A learned model in a control loop, from C++: load a model file of any
// estimator, make its query workspace once, then ask for the feed-forward
// torque once per 1 kHz tick along a smooth motion and report the latency
// distribution of those queries (p50, p99, max). For models with the
// rigid-body structure the gravity torque and the inertia diagonal at one
// state are printed too.
//   build/control_loop_cpp [MODEL] [CALLS]    (no MODEL, or "-": train a small SCARA model; CALLS: 100000)
// Its twins: examples/c/control_loop.c (the C API) and examples/python/control_loop.py.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace {

// A small SCARA model, so that the example runs without a model file: 300
// samples over 15 s, trained without a teacher (seconds).
std::unique_ptr<gipdyn::Estimator> small_scara_model() {
  const gipdyn::RobotModel scara = gipdyn::scara_robot();
  gipdyn::SimulationOptions sim;
  sim.samples = 300;
  sim.dt = 0.05;
  sim.seed = 1;
  const gipdyn::SimulationResult log = gipdyn::simulate(scara, sim);
  gipdyn::FitResult fit = gipdyn::fit_estimator(gipdyn::EstimatorOptions{}, log.X, log.tau, scara.joint_types());
  if (!fit.report.ok()) throw gipdyn::Error("training the SCARA model failed: " + fit.report.message);
  return std::move(fit.estimator);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "-";
  const long calls = argc > 2 ? std::atol(argv[2]) : 100000;
  if (calls < 1) {
    std::fprintf(stderr, "control_loop_cpp: CALLS must be at least 1\n");
    return 2;
  }
  // Loading and the workspace may allocate and throw; the loop below does neither.
  std::unique_ptr<gipdyn::Estimator> model;
  std::unique_ptr<gipdyn::QueryWorkspace> workspace;
  try {
    model = path == "-" ? small_scara_model() : gipdyn::load_estimator(path);
    workspace = model->make_query_workspace();
  } catch (const gipdyn::Error& e) {
    std::fprintf(stderr, "control_loop_cpp: %s\n", e.what());
    return 1;
  }
  const int n = model->joints().size();

  std::vector<double> x(3 * n), tau(n), latency_ns(calls);
  double checksum = 0.0;
  for (long k = 0; k < calls; ++k) {
    const double t = 0.001 * static_cast<double>(k);  // 1 kHz ticks
    for (int i = 0; i < n; ++i) {
      const double w = 0.5 + 0.1 * i;
      x[i] = 0.5 * std::sin(w * t + i);
      x[n + i] = 0.5 * w * std::cos(w * t + i);
      x[2 * n + i] = -0.5 * w * w * std::sin(w * t + i);
    }
    const auto start = std::chrono::steady_clock::now();
    workspace->predict(x.data(), tau.data());
    latency_ns[k] = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
    checksum += tau[0];
  }
  std::sort(latency_ns.begin(), latency_ns.end());
  std::printf("%ld torque queries, %d joints (%s, %s): p50 %.1f us, p99 %.1f us, max %.1f us (checksum %.6g)\n", calls,
              n, model->name().c_str(), workspace->allocation_free() ? "allocation-free" : "allocates",
              latency_ns[calls / 2] / 1e3, latency_ns[static_cast<long>(0.99 * static_cast<double>(calls - 1))] / 1e3,
              latency_ns[calls - 1] / 1e3, checksum);

  if (!model->gives_rigid_body_terms()) {
    std::printf("no gravity or inertia from a %s model (they need the rigid-body structure: docs/method.md section 9)\n",
                model->name().c_str());
    return 0;
  }
  const Eigen::MatrixXd q = Eigen::MatrixXd::Constant(1, n, 0.3);
  const Eigen::MatrixXd g = gipdyn::gravity(*model, q);
  const Eigen::MatrixXd M = gipdyn::inertia(*model, q).front();
  std::printf("gravity at q = 0.3:");
  for (int i = 0; i < n; ++i) std::printf(" %.4g", g(0, i));
  std::printf("\ninertia diagonal at q = 0.3:");
  for (int i = 0; i < n; ++i) std::printf(" %.4g", M(i, i));
  std::printf("\n");
  return 0;
}
