// `gipdyn simulate`: a robot on a random trajectory, written as a training CSV.
#include <cstdio>
#include <memory>

#include "exit_codes.hpp"
#include "commands.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "reports/plots.hpp"

namespace gipdyn::cli {

Command add_simulate(CLI::App& app) {
  struct Args {
    std::string robot, out, model, integrator = "rk4", plot;
    SimulationOptions sim;
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--robot", a->robot, "scara, ur10, a URDF file (FILE.urdf:LINK ends the chain at LINK where the tree branches) or a JSON DH description (docs/robot-format.md)")
      ->required();
  app.add_option("--samples", a->sim.samples, "Number of samples")->capture_default_str();
  app.add_option("--seed", a->sim.seed, "Seed of the trajectory, the noise and the perturbation")->capture_default_str();
  app.add_option("--noise", a->sim.noise_std, "Standard deviation of the Gaussian torque noise (N m)")
      ->capture_default_str();
  app.add_option("--dt", a->sim.dt,
                 "Sampling period in seconds. The motion lasts samples x dt, and a longer one covers more of the "
                 "joint space: 2000 samples at dt 0.1 or 1 learn far better than at 0.01 (docs/training.md)")
      ->capture_default_str();
  app.add_option("--max-frequency", a->sim.trajectory.max_angular_frequency,
                 "Highest angular frequency of the trajectory's sinusoids (rad/s): higher gives faster motions")
      ->capture_default_str();
  app.add_option("--velocity-fill", a->sim.trajectory.velocity_fill,
                 "Fraction (0, 1] of each joint's velocity limit the trajectory may reach")
      ->capture_default_str();
  app.add_flag("--perturb-kinematics", a->sim.perturb_kinematics,
               "Generate the data with lengths perturbed by up to 0.05 m and angles by up to 5 deg");
  app.add_flag("--friction", a->sim.friction, "Add the robot's viscous and Coulomb friction to the torques");
  app.add_option("--contacts", a->sim.contacts.count,
                 "Contacts: this many constant external torques on the joints, drawn with --seed. The robot then "
                 "follows the trajectory under a PD controller, the contacts act through its dynamics, and "
                 "ext1_true..extn_true hold the true external torque (for `gipdyn detect`)")
      ->capture_default_str();
  app.add_option("--contact-size", a->sim.contacts.size,
                 "--contacts: each contact's torque as a fraction of its joint's torque range")
      ->capture_default_str();
  app.add_option("--contact-duration", a->sim.contacts.duration, "--contacts: each contact's duration in seconds")
      ->capture_default_str();
  app.add_option("--contact-joint", a->sim.contacts.joint,
                 "--contacts: the joint (1..n) every contact acts on; 0: a joint drawn for each")
      ->capture_default_str();
  app.add_option("--contact-bandwidth", a->sim.contacts.bandwidth,
                 "--contacts: the PD controller's bandwidth in rad/s")
      ->capture_default_str();
  app.add_option("--model", a->model,
                 "A learned model (" + joined(physics_estimator_names()) + ") driven by the same noise-free torques from the same start: "
                 "adds its motion as q1_model.., qd1_model.. columns")
      ->check(CLI::ExistingFile);
  app.add_option("--integrator", a->integrator, "--model: rk4 (torque interpolated linearly) or euler (semi-implicit, torque held)")
      ->capture_default_str();
  app.add_option("--plot", a->plot, "--model: PNG of true and learned positions and their difference over time");
  app.add_option("--out", a->out, "Output CSV (a sidecar OUT.json records how to regenerate it)")->required();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    refuse_overwrites({{"--robot", a->robot}, {"--model", a->model}},
                      {{"--out", a->out}, {"--out (its .json sidecar)", a->out + ".json"}, {"--plot", a->plot}});
    if (a->model.empty() && !a->plot.empty()) throw Error("--plot draws the learned motion: give --model too");
    if (a->integrator != "rk4" && a->integrator != "euler")
      throw Error("--integrator '" + a->integrator + "' is unknown; choose rk4 or euler");
    const RobotModel robot = load_robot(a->robot);
    std::unique_ptr<Estimator> learned;
    if (!a->model.empty()) {
      learned = load_estimator(a->model);
      if (learned->joints().str() != robot.joint_types().str())
        throw Error("--model is a " + learned->joints().str() + " model but --robot " + a->robot + " has joints " +
                    robot.joint_types().str());
      require_physics(*learned);
    }
    SimulationResult r = simulate(robot, a->sim);
    r.metadata["robot_spec"] = a->robot;
    const int n = robot.num_joints();
    std::vector<std::string> header = input_column_names(n);
    for (const char* suffix : {"", "_true"}) {
      const auto t = torque_column_names(n, suffix);
      header.insert(header.end(), t.begin(), t.end());
    }
    Eigen::MatrixXd all(r.X.rows(), 5 * n + r.external.cols());
    if (r.external.size() > 0) {
      all << r.X, r.tau, r.tau_true, r.external;
      const auto ext = external_torque_column_names(n, "_true");
      header.insert(header.end(), ext.begin(), ext.end());
    } else {
      all << r.X, r.tau, r.tau_true;
    }
    if (learned) {
      const Eigen::VectorXd q0 = r.X.row(0).head(n).transpose(), qd0 = r.X.row(0).segment(n, n).transpose();
      const Eigen::MatrixXd motion = integrate_forward_dynamics(
          *learned, q0, qd0, r.external.size() > 0 ? Eigen::MatrixXd(r.tau_true + r.external) : r.tau_true, a->sim.dt, a->integrator == "rk4" ? Integrator::Rk4 : Integrator::SemiImplicitEuler);
      for (const auto& name : input_column_names(n)) header.push_back(name + "_model");
      Eigen::MatrixXd with_model(all.rows(), all.cols() + motion.cols());
      with_model << all, motion;
      all = with_model;
      r.metadata["model"] = a->model;
      r.metadata["integrator"] = a->integrator;
    }
    write_csv_with_sidecar(a->out, header, all, r.metadata);
    const std::string sidecar = a->out + ".json";
    if (!a->quiet)
      std::printf("simulated %d samples of %s (%s, dt %g s%s%s) -> %s (+ %s)\n", a->sim.samples, robot.name().c_str(),
                  robot.joint_types().str().c_str(), a->sim.dt, a->sim.perturb_kinematics ? ", perturbed kinematics" : "",
                  a->sim.friction ? ", friction" : "", a->out.c_str(), sidecar.c_str());
    if (!a->quiet && a->sim.contacts.count > 0)
      std::printf("with %d contacts of %g s (true external torque in ext1_true..ext%d_true)\n", a->sim.contacts.count,
                  a->sim.contacts.duration, n);
    if (learned && !a->quiet) {
      // How far the learned robot drifts from the true one under the same torques.
      const Eigen::MatrixXd error = (all.rightCols(3 * n).leftCols(n) - r.X.leftCols(n)).cwiseAbs();
      std::printf("learned model %s (%s): max position error per joint", a->model.c_str(), a->integrator.c_str());
      for (int j = 0; j < n; ++j) std::printf(" %.3g", error.col(j).maxCoeff());
      std::printf("; after 1 s");
      const Eigen::Index one_second = std::min<Eigen::Index>(error.rows(), static_cast<Eigen::Index>(1.0 / a->sim.dt) + 1);
      for (int j = 0; j < n; ++j) std::printf(" %.3g", error.col(j).head(one_second).maxCoeff());
      std::printf("\n");
    }
    if (!a->plot.empty()) {
      const PlotResult p = render_plot("motion", a->out, a->plot);
      if (!p.ok) {
        std::fprintf(stderr, "gipdyn: warning: %s\n", p.message.c_str());
        return kExitFailure;  // the data are written
      }
    }
    return 0;
  };
}

}  // namespace gipdyn::cli
