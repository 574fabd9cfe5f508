#include "gipdyn/sim/simulate.hpp"

#include <random>

#include "gipdyn/error.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/robot/dynamics.hpp"

namespace gipdyn {
namespace {

std::uint64_t derive_seed(std::uint64_t seed, std::uint32_t stream) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32), stream};
  std::uint32_t out[2];
  seq.generate(out, out + 2);
  return (static_cast<std::uint64_t>(out[0]) << 32) | out[1];
}

}  // namespace

void SimulationOptions::validate() const {
  if (samples < 1) throw Error("SimulationOptions::samples must be at least 1");
  if (!(noise_std >= 0.0)) throw Error("SimulationOptions::noise_std must be >= 0");
  if (!(dt > 0.0)) throw Error("SimulationOptions::dt must be positive");
  if (!(perturb_length >= 0.0) || !(perturb_angle_deg >= 0.0)) throw Error("SimulationOptions::perturb_length and perturb_angle_deg must be >= 0");
  trajectory.validate();
}

SimulationResult simulate(const RobotModel& nominal, const SimulationOptions& o) {
  o.validate();
  if (o.friction) nominal.require_friction("SimulationOptions::friction");
  // X, tau and tau_true, and their copies on the way out.
  require_memory(4.0 * 8.0 * o.samples * 5.0 * nominal.num_joints(),
                 "simulating " + std::to_string(o.samples) + " samples", "ask for fewer SimulationOptions::samples");
  SimulationResult r;
  nlohmann::json drawn = nullptr;
  const RobotModel robot = o.perturb_kinematics
                               ? nominal.with_perturbed_kinematics(derive_seed(o.seed, 3), o.perturb_length,
                                                                   o.perturb_angle_deg * M_PI / 180.0, &drawn)
                               : nominal;
  const SinusoidTrajectory traj = SinusoidTrajectory::random(robot, o.samples, o.dt, derive_seed(o.seed, 1), o.trajectory);
  r.X = traj.sample(o.samples, o.dt);
  r.tau_true = inverse_dynamics(robot, r.X, o.friction);
  std::mt19937_64 rng(derive_seed(o.seed, 2));
  std::normal_distribution<double> noise(0.0, 1.0);
  r.tau = r.tau_true;
  if (o.noise_std > 0.0)
    for (Eigen::Index c = 0; c < r.tau.cols(); ++c)
      for (Eigen::Index s = 0; s < r.tau.rows(); ++s) r.tau(s, c) += o.noise_std * noise(rng);
  r.metadata = {{"generator", kSimulationGenerator},
                {"robot", nominal.name()},
                {"joints", nominal.joint_types().str()},
                {"samples", o.samples},
                {"seed", o.seed},
                {"dt", o.dt},
                {"noise_std", o.noise_std},
                {"friction", o.friction},
                {"perturb_kinematics", o.perturb_kinematics},
                {"perturb_length_m", o.perturb_length},
                {"perturb_angle_deg", o.perturb_angle_deg},
                {"perturbation", drawn},
                {"trajectory",
                 {{"sinusoids", o.trajectory.sinusoids},
                  {"max_angular_frequency", o.trajectory.max_angular_frequency},
                  {"position_fill", o.trajectory.position_fill},
                  {"velocity_fill", o.trajectory.velocity_fill}}}};
  if (nominal.is_dh()) r.metadata["nominal_robot"] = nominal.to_json();
  return r;
}

}  // namespace gipdyn
