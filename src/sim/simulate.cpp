#include "gipdyn/sim/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "gipdyn/error.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/sim/closed_loop.hpp"

namespace gipdyn {
namespace {

std::uint64_t derive_seed(std::uint64_t seed, std::uint32_t stream) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32), stream};
  std::uint32_t out[2];
  seq.generate(out, out + 2);
  return (static_cast<std::uint64_t>(out[0]) << 32) | out[1];
}

struct Contact {
  double start = 0.0;  // s
  int joint = 0;       // 0-based
  double torque = 0.0;
};

// count contacts, one in each of count equal slots of the motion (the rows of reference_torque at dt), at
// least one duration apart, each of c.size times its joint's torque range.
std::vector<Contact> draw_contacts(const SimulatedContacts& c, const Eigen::MatrixXd& reference_torque, double dt,
                                   std::uint64_t seed, nlohmann::json* drawn) {
  const auto joints = static_cast<int>(reference_torque.cols());
  const double motion_time = static_cast<double>(reference_torque.rows()) * dt;
  const Eigen::VectorXd torque_range =
      reference_torque.colwise().maxCoeff() - reference_torque.colwise().minCoeff();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> joint(0, joints - 1);
  const double slot = motion_time / c.count;
  std::vector<Contact> contacts;
  for (int i = 0; i < c.count; ++i) {
    Contact k;
    k.start = i * slot + 0.5 * c.duration + unit(rng) * (slot - 2.0 * c.duration);
    k.joint = c.joint > 0 ? c.joint - 1 : joint(rng);
    k.torque = (unit(rng) < 0.5 ? -1.0 : 1.0) * c.size * torque_range(k.joint);
    contacts.push_back(k);
  }
  if (drawn) {
    *drawn = nlohmann::json::array();
    for (const Contact& k : contacts)
      drawn->push_back({{"start_s", k.start}, {"joint", k.joint + 1}, {"torque", k.torque}});
  }
  return contacts;
}

void add_external_torque(const std::vector<Contact>& contacts, double duration, double t,
                         Eigen::Ref<Eigen::VectorXd> ext) {
  ext.setZero();
  for (const Contact& k : contacts)
    if (t >= k.start && t < k.start + duration) ext(k.joint) += k.torque;
}

// The robot driven along the reference by a PD around its own torques, with
// the contacts acting on it: rows of (q, qd, qdd) and the controller's torque.
void simulate_with_contacts(const RobotModel& robot, const SinusoidTrajectory& traj, const SimulationOptions& o,
                            std::uint64_t contact_seed, SimulationResult& r, nlohmann::json& drawn) {
  const int n = robot.num_joints();
  const Eigen::MatrixXd reference = r.X;
  const Eigen::MatrixXd reference_torque = r.tau_true;
  const std::vector<Contact> contacts = draw_contacts(o.contacts, reference_torque, o.dt, contact_seed, &drawn);

  Eigen::VectorXd kp, kd;
  critically_damped_gains(robot, reference.row(0).head(n).transpose(), o.contacts.bandwidth, kp, kd);
  Eigen::MatrixXd M;
  Eigen::VectorXd h;
  // The controller runs ten times per logged row and at least at 1 kHz, so
  // that the logged torque samples a torque that varies within a row, as a
  // robot's measured torque does, rather than one held over the row.
  const int substeps = std::max(10, static_cast<int>(std::ceil(o.dt / 1e-3 - 1e-9)));
  const double step = o.dt / substeps;

  Eigen::VectorXd q = reference.row(0).head(n).transpose(), qd = reference.row(0).segment(n, n).transpose();
  Eigen::VectorXd q_ref(n), qd_ref(n), qdd_ref(n), ext(n), tau(n);
  const auto control = [&](double t) {
    traj.evaluate(t, q_ref, qd_ref, qdd_ref);
    tau = inverse_dynamics(robot, q_ref, qd_ref, qdd_ref, o.friction) + kp.cwiseProduct(q_ref - q) +
          kd.cwiseProduct(qd_ref - qd);
    add_external_torque(contacts, o.contacts.duration, t, ext);
  };
  r.external.resize(o.samples, n);
  for (int k = 0; k < o.samples; ++k) {
    for (int s = 0; s < substeps; ++s) {
      const double t = k * o.dt + s * step;
      control(t);
      mass_matrix_and_bias(robot, q, qd, o.friction, M, h);
      const Eigen::VectorXd qdd = M.ldlt().solve(tau + ext - h);
      if (s == 0) {
        r.X.row(k) << q.transpose(), qd.transpose(), qdd.transpose();
        r.tau_true.row(k) = tau.transpose();
        r.external.row(k) = ext.transpose();
      }
      qd += step * qdd;
      q += step * qd;
    }
    if (!q.allFinite() || !qd.allFinite())
      throw Error("the simulated robot diverged under its contacts at row " + std::to_string(k + 1) +
                  ": ask for smaller contacts (SimulatedContacts::size) or a lower SimulatedContacts::bandwidth");
  }
}

}  // namespace

nlohmann::json SimulatedContacts::to_json(bool with_bandwidth) const {
  nlohmann::json j{{"count", count}, {"size", size}, {"duration_s", duration}, {"joint", joint}};
  if (with_bandwidth) j["bandwidth"] = bandwidth;
  return j;
}

void SimulatedContacts::validate(int joints, int samples, double dt) const {
  if (count < 0) throw Error("SimulatedContacts::count must be >= 0");
  if (count == 0) return;
  if (!(size > 0.0) || !std::isfinite(size)) throw Error("SimulatedContacts::size must be a positive fraction of the torque range");
  if (!(duration > 0.0) || !std::isfinite(duration)) throw Error("SimulatedContacts::duration must be a positive number of seconds");
  if (joint < 0 || joint > joints)
    throw Error("SimulatedContacts::joint must be 0 (drawn at random) or a joint from 1 to " + std::to_string(joints));
  if (!(bandwidth > 0.0) || !std::isfinite(bandwidth)) throw Error("SimulatedContacts::bandwidth must be > 0 rad/s");
  if (samples * dt < 3.0 * duration * count) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "SimulatedContacts::count (%d) contacts of SimulatedContacts::duration (%g s) need a motion of at "
                  "least 3 x count x duration = %g s, and this one lasts %g s: ask for fewer or shorter contacts, "
                  "or a longer motion",
                  count, duration, 3.0 * duration * count, samples * dt);
    throw Error(buf);
  }
}

void SimulationOptions::validate() const {
  if (samples < 1) throw Error("SimulationOptions::samples must be at least 1");
  if (!(noise_std >= 0.0)) throw Error("SimulationOptions::noise_std must be >= 0");
  if (!(dt > 0.0)) throw Error("SimulationOptions::dt must be positive");
  if (!(perturb_length >= 0.0) || !(perturb_angle_deg >= 0.0)) throw Error("SimulationOptions::perturb_length and perturb_angle_deg must be >= 0");
  trajectory.validate();
}

Eigen::MatrixXd contact_torques(const SimulatedContacts& contacts, const Eigen::MatrixXd& reference_torque, double dt,
                                std::uint64_t seed, nlohmann::json* drawn) {
  const auto rows = static_cast<int>(reference_torque.rows());
  contacts.validate(static_cast<int>(reference_torque.cols()), rows, dt);
  Eigen::MatrixXd external = Eigen::MatrixXd::Zero(rows, reference_torque.cols());
  if (contacts.count == 0) {
    if (drawn) *drawn = nlohmann::json::array();
    return external;
  }
  const std::vector<Contact> drawn_contacts = draw_contacts(contacts, reference_torque, dt, seed, drawn);
  Eigen::VectorXd ext(reference_torque.cols());
  for (int k = 0; k < rows; ++k) {
    add_external_torque(drawn_contacts, contacts.duration, k * dt, ext);
    external.row(k) = ext.transpose();
  }
  return external;
}

SimulationResult simulate(const RobotModel& nominal, const SimulationOptions& o) {
  o.validate();
  o.contacts.validate(nominal.num_joints(), o.samples, o.dt);
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
  nlohmann::json drawn_contacts = nullptr;
  if (o.contacts.count > 0) simulate_with_contacts(robot, traj, o, derive_seed(o.seed, 4), r, drawn_contacts);
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
  if (o.contacts.count > 0) {
    r.metadata["contacts"] = o.contacts.to_json(true);
    r.metadata["contacts"]["drawn"] = drawn_contacts;
  }
  if (nominal.is_dh()) r.metadata["nominal_robot"] = nominal.to_json();
  return r;
}

}  // namespace gipdyn
