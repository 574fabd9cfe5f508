// One short log: LIP for accuracy, and a fast GIP model that learns from LIP.
//
// On one 20 s motion, GIP's own marginal-likelihood optimum picks monomials
// the robot does not have and extrapolates badly to a new motion; LIP, whose
// torques come from two shared energies, does not (docs/results/training.md, "What one
// 20 s motion lacks"). This example trains GIP on one short simulated SCARA
// log, then GIP taught by LIP (EstimatorOptions::teacher): LIP is fitted on
// the log, and GIP learns from LIP's torques at states drawn uniformly from
// the log's box. The teacher is compared too. On a real robot's log use the
// preset "real" instead (examples/cpp/real_log.cpp).
//   build/short_log [SAMPLES] [HYPERPARAMETER_ROWS] [STATES] [MAX_ITER]
// Defaults 2000, 300, 2000 and the library's cap: 77 s on 2 cores (GIP on the log 51 s, GIP taught by
// LIP 25 s; test nMSE on joints 1-4 1e-4 to 2e-2, and 9e-8 to 2e-4 taught).
// STATES is the number of drawn states (TeacherOptions::states).
// Its Python twin is examples/python/short_log.py; `gipdyn train --teacher lip` does the same.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace {

double p50_query_us(const gipdyn::Estimator& model, const Eigen::MatrixXd& X) {
  const std::unique_ptr<gipdyn::QueryWorkspace> workspace = model.make_query_workspace();
  std::vector<double> us;
  Eigen::VectorXd x, tau(X.cols() / 3);
  for (Eigen::Index r = 0; r < std::min<Eigen::Index>(200, X.rows()); ++r) {
    x = X.row(r).transpose();
    const auto start = std::chrono::steady_clock::now();
    workspace->predict(x.data(), tau.data());
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
  }
  std::nth_element(us.begin(), us.begin() + us.size() / 2, us.end());
  return us[us.size() / 2];
}

void print_row(const char* name, const gipdyn::Estimator& model, const gipdyn::SimulationResult& test) {
  const Eigen::VectorXd nmse = gipdyn::compute_accuracy(test.tau_true, model.predict(test.X)).nmse;
  std::printf("  %-18s joints 1-4:", name);
  for (Eigen::Index j = 0; j < nmse.size(); ++j) std::printf(" %9.2e", nmse(j));
  std::printf("   p50 %8.1f us\n", p50_query_us(model, test.X));
}

}  // namespace

int main(int argc, char** argv) {
  const int samples = argc > 1 ? std::atoi(argv[1]) : 2000;
  gipdyn::TeacherOptions teacher;  // LIP, kept whatever its check says (TeachingMode::Always)
  if (argc > 2) teacher.hyperparameter_rows = std::atoi(argv[2]);
  if (argc > 3) teacher.states = std::atoi(argv[3]);
  gipdyn::EstimatorOptions gip;  // "gip" on the log
  if (argc > 4) gip.search.optimizer.max_iterations = std::atoi(argv[4]);

  try {
    // One 20 s motion at 100 Hz to learn from, another to test on.
    const gipdyn::RobotModel scara = gipdyn::scara_robot();
    gipdyn::SimulationOptions sim;
    sim.samples = samples;
    sim.seed = 1;
    const gipdyn::SimulationResult train = gipdyn::simulate(scara, sim);
    sim.seed = 2;
    const gipdyn::SimulationResult test = gipdyn::simulate(scara, sim);

    gipdyn::EstimatorOptions taught = gip;
    taught.teacher = teacher;
    std::vector<gipdyn::FitResult> fits;
    for (const gipdyn::EstimatorOptions* options : {&gip, &taught}) {
      const auto start = std::chrono::steady_clock::now();
      fits.push_back(gipdyn::fit_estimator(*options, train.X, train.tau, scara.joint_types()));
      if (!fits.back().report.ok()) {
        std::fprintf(stderr, "short_log: %s\n", fits.back().report.message.c_str());
        return 1;
      }
      std::printf("%s: trained in %.0f s\n", options->teacher ? "GIP taught by LIP" : "GIP on the log",
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    const gipdyn::FitResult& lesson = fits.back();
    std::printf("label noise (LIP's RMS residual on the log), per joint:");
    for (Eigen::Index j = 0; j < lesson.label_noise_std.size(); ++j) std::printf(" %.3g", lesson.label_noise_std(j));
    std::printf("\n\nnMSE on a new 20 s motion (noise-free torque), and one query's p50:\n");
    print_row("GIP on the log", *fits.front().estimator, test);
    print_row("LIP", *lesson.teacher, test);
    print_row("GIP taught by LIP", *lesson.estimator, test);
  } catch (const gipdyn::Error& e) {
    std::fprintf(stderr, "short_log: %s\n", e.what());
    return 1;
  }
  return 0;
}
