// `gipdyn simulate`: a robot on a random trajectory, written as a training CSV.
#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace gipdyn::cli {

Command add_simulate(CLI::App& app) {
  struct Args {
    std::string robot, out;
    SimulationOptions sim;
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--robot", a->robot, "scara, ur10, a URDF file or a JSON DH description (docs/robot-format.md)")
      ->required();
  app.add_option("--samples", a->sim.samples, "Number of samples")->capture_default_str();
  app.add_option("--seed", a->sim.seed, "Seed of the trajectory, the noise and the perturbation")->capture_default_str();
  app.add_option("--noise", a->sim.noise_std, "Standard deviation of the Gaussian torque noise (N m)")
      ->capture_default_str();
  app.add_option("--dt", a->sim.dt, "Sampling period in seconds")->capture_default_str();
  app.add_flag("--perturb-kinematics", a->sim.perturb_kinematics,
               "Generate the data with lengths perturbed by up to 0.05 m and angles by up to 5 deg");
  app.add_flag("--friction", a->sim.friction, "Add the robot's viscous and Coulomb friction to the torques");
  app.add_option("--out", a->out, "Output CSV (a sidecar OUT.json records how to regenerate it)")->required();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    refuse_overwriting_inputs({{"--robot", a->robot}}, {{"--out", a->out}, {"--out (its .json sidecar)", a->out + ".json"}});
    const RobotModel robot = load_robot(a->robot);
    SimulationResult r = simulate(robot, a->sim);
    r.metadata["robot_spec"] = a->robot;
    const int n = robot.num_joints();
    std::vector<std::string> header = input_column_names(n);
    for (const char* suffix : {"", "_true"}) {
      const auto t = torque_column_names(n, suffix);
      header.insert(header.end(), t.begin(), t.end());
    }
    Eigen::MatrixXd all(r.X.rows(), 5 * n);
    all << r.X, r.tau, r.tau_true;
    write_csv_with_sidecar(a->out, header, all, r.metadata);
    const std::string sidecar = a->out + ".json";
    if (!a->quiet)
      std::printf("simulated %d samples of %s (%s, dt %g s%s%s) -> %s (+ %s)\n", a->sim.samples, robot.name().c_str(),
                  robot.joint_types().str().c_str(), a->sim.dt, a->sim.perturb_kinematics ? ", perturbed kinematics" : "",
                  a->sim.friction ? ", friction" : "", a->out.c_str(), sidecar.c_str());
    return 0;
  };
}

}  // namespace gipdyn::cli
