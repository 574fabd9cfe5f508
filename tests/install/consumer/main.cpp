// Trains a small GIP model through the installed umbrella header and checks
// that it learned: exit 0 only if the test nMSE of every joint is small.
#include <gipdyn/gipdyn.hpp>

#include <cstdio>

int main() {
  gipdyn::SimulationOptions sim;
  sim.samples = 150;
  sim.dt = 0.1;
  sim.seed = 1;
  const gipdyn::RobotModel robot = gipdyn::load_robot("scara");
  const gipdyn::SimulationResult train = gipdyn::simulate(robot, sim);
  sim.seed = 2;
  const gipdyn::SimulationResult test = gipdyn::simulate(robot, sim);
  gipdyn::TrainOptions options;
  options.search.optimizer.max_iterations = 30;
  const gipdyn::TrainResult r = gipdyn::train_model(train.X, train.tau, robot.joint_types(), options);
  if (!r.report.ok()) {
    std::fprintf(stderr, "training failed: %s\n", r.report.message.c_str());
    return 1;
  }
  const Eigen::VectorXd nmse = gipdyn::compute_accuracy(test.tau_true, r.model.predict(test.X)).nmse;
  std::printf("consumer: nMSE %g %g %g %g\n", nmse(0), nmse(1), nmse(2), nmse(3));
  return nmse.head(3).maxCoeff() < 0.05 ? 0 : 1;
}
