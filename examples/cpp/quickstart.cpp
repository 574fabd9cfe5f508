// Quickstart (C++): simulate a SCARA, train a GIP model, report the nMSE and
// predict one sample through the allocation-free control-loop path.
//   build/quickstart [SAMPLES] [MAX_ITER]
// Its Python twin is examples/python/quickstart.py.
#include <cstdio>
#include <cstdlib>

#include "gipdyn/metrics.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

int main(int argc, char** argv) {
  const int samples = argc > 1 ? std::atoi(argv[1]) : 2000;
  const int max_iter = argc > 2 ? std::atoi(argv[2]) : gipdyn::OptimizerOptions{}.max_iterations;

  const gipdyn::RobotModel scara = gipdyn::scara_robot();
  gipdyn::SimulationOptions sim;
  sim.samples = samples;
  sim.seed = 1;
  const gipdyn::SimulationResult train = gipdyn::simulate(scara, sim);
  sim.seed = 2;
  const gipdyn::SimulationResult test = gipdyn::simulate(scara, sim);

  gipdyn::TrainOptions options;  // kernel "gip", L-BFGS
  options.search.optimizer.max_iterations = max_iter;
  const gipdyn::TrainResult result = gipdyn::train_model(train.X, train.tau, scara.joint_types(), options);
  if (!result.report.ok()) {
    std::fprintf(stderr, "training failed: %s\n", result.report.message.c_str());
    return 1;
  }
  const gipdyn::Accuracy acc = gipdyn::compute_accuracy(test.tau_true, result.model.predict(test.X));
  std::printf("GIP on a simulated SCARA, %d training samples\n", samples);
  for (int j = 0; j < 4; ++j) std::printf("  joint %d  nMSE %.3g\n", j + 1, acc.nmse(j));

  gipdyn::PredictionWorkspace control_loop(result.model);
  Eigen::VectorXd x = test.X.row(0).transpose(), tau(4);
  control_loop.predict(x.data(), tau.data());
  std::printf("one sample: predicted tau = [%.4f %.4f %.4f %.4f], true = [%.4f %.4f %.4f %.4f]\n", tau(0), tau(1),
              tau(2), tau(3), test.tau_true(0, 0), test.tau_true(0, 1), test.tau_true(0, 2), test.tau_true(0, 3));
  return 0;
}
