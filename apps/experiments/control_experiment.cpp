#include "experiments/control_experiment.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <ostream>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/closed_loop.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "reports/plots.hpp"
#include "reports/text_format.hpp"

namespace fs = std::filesystem;

namespace gipdyn {

void ControlConfig::validate() const {
  if (!(seconds > 0.0) || !(dt > 0.0) || seconds / dt > 1e7)
    throw Error("--seconds and --dt must be > 0, with at most 10^7 control steps");
  if (!(bandwidth > 0.0)) throw Error("--bandwidth must be > 0 (rad/s)");
  if (out.empty()) throw Error("--out is required: the folder for the experiment's files");
}

nlohmann::json ControlConfig::to_json() const {
  nlohmann::json j{{"experiment", "control"}, {"robot", robot},         {"models", models},   {"seconds", seconds},
                   {"dt", dt},                {"bandwidth", bandwidth}, {"friction", friction}, {"seed", seed},
                   {"position_noise", position_noise}, {"velocity_noise", velocity_noise}};
  if (contacts.count > 0)
    j["contacts"] = contacts.to_json(false);  // the closed loop's controllers, not the PD of simulate
  return j;
}

namespace {

// "models/gip.gipdyn" -> "gip"
std::string controller_name(const std::string& path) { return fs::path(path).stem().string(); }

// A Markdown table: one row per controller, one column per joint, the given
// per-joint figure; controllers that diverged get "diverged" in every column.
void joint_table(std::ostream& o, int n, const std::vector<std::pair<std::string, TrackingResult>>& results,
                 const std::vector<std::pair<std::string, std::string>>& diverged,
                 Eigen::VectorXd TrackingResult::*figure) {
  std::vector<std::string> columns{"controller"};
  for (const std::string& c : joint_columns(n)) columns.push_back(c);
  o << markdown_table_header(columns);
  for (const auto& [name, r] : results) {
    o << "| " << name << " |";
    for (int j = 0; j < n; ++j) o << " " << sci((r.*figure)(j)) << " |";
    o << "\n";
  }
  for (const auto& [name, why] : diverged) {
    o << "| " << name << " |";
    for (int j = 0; j < n; ++j) o << " diverged |";
    o << "\n";
  }
}

// summary.md: the set-up, then RMS error and torque per controller and joint; its path.
std::string write_summary(const ControlConfig& c, const RobotModel& robot,
                          const std::vector<std::pair<std::string, TrackingResult>>& results,
                          const std::vector<std::pair<std::string, std::string>>& diverged,
                          const nlohmann::json& drawn_contacts) {
  const int n = robot.num_joints();
  const std::string summary = (fs::path(c.out) / "summary.md").string();
  write_file_atomically(summary, [&](std::ostream& o) {
    o << "# Closed-loop tracking: " << robot.name() << " (" << robot.joint_types().str() << ")\n\n"
      << "The simulated robot" << (c.friction ? " (with friction)" : "") << " follows a " << c.seconds
      << " s reference (seed " << c.seed << ") at " << 1.0 / c.dt << " Hz under PD feedback, critically damped at "
      << c.bandwidth << " rad/s on each joint's inertia, plus each controller's feed-forward torque along the "
      << "reference. Rows ending in -ct use computed-torque control instead: the model is asked, at the measured "
      << "state, for the torque of the reference acceleration plus a critically damped correction at the same "
      << "bandwidth.";
    if (c.position_noise > 0.0 || c.velocity_noise > 0.0)
      o << " Every controller measures the state with Gaussian sensor noise (std " << c.position_noise
        << " on positions, " << c.velocity_noise << " on velocities; the same sequence for all, seed " << c.seed
        << ").";
    if (c.contacts.count > 0) {
      o << " " << c.contacts.count << " contacts of " << c.contacts.duration << " s push the robot, each of "
        << c.contacts.size << " times its joint's torque range along the reference, the same for every "
        << "controller (external.csv); no controller is told of them. They act at";
      for (size_t i = 0; i < drawn_contacts.size(); ++i) {
        const nlohmann::json& k = drawn_contacts[i];
        char buf[96];
        std::snprintf(buf, sizeof buf, "%s %.3f s on joint %d (%+.3g)", i == 0 ? "" : ",", k.at("start_s").get<double>(),
                      k.at("joint").get<int>(), k.at("torque").get<double>());
        o << buf;
      }
      o << ".";
    }
    o << "\n\n"
      << "RMS position error per joint (rad or m):\n\n";
    joint_table(o, n, results, diverged, &TrackingResult::rms_error);
    for (const auto& [name, why] : diverged) o << "\n- " << name << ": " << why << "\n";
    if (c.contacts.count > 0) {
      o << "\nLargest position error per joint (rad or m), the contacts' push included:\n\n";
      joint_table(o, n, results, {}, &TrackingResult::max_error);
    }
    o << "\nRMS torque per joint:\n\n";
    joint_table(o, n, results, {}, &TrackingResult::rms_torque);
  });
  return summary;
}

}  // namespace

ExperimentOutcome run_control_experiment(const ControlConfig& c, const ProgressCallback& progress) {
  c.validate();
  const RobotModel robot = load_robot(c.robot);
  const int n = robot.num_joints();
  // Every model is loaded and checked before any work or output.
  std::vector<std::pair<std::string, std::unique_ptr<Estimator>>> models;
  for (const auto& path : c.models) {
    auto e = load_estimator(path);
    if (e->joints().str() != robot.joint_types().str())
      throw Error("model " + path + " is for joints " + e->joints().str() + " but the robot " + c.robot + " has " +
                  robot.joint_types().str());
    models.emplace_back(controller_name(path), std::move(e));
  }
  SimulationOptions so;
  so.samples = static_cast<int>(std::lround(c.seconds / c.dt));
  so.dt = c.dt;
  so.seed = c.seed;
  so.noise_std = 0.0;
  const SimulationResult reference = simulate(robot, so);
  TrackingOptions to;
  to.dt = c.dt;
  to.bandwidth = c.bandwidth;
  to.friction = c.friction;
  to.position_noise = c.position_noise;
  to.velocity_noise = c.velocity_noise;
  to.noise_seed = c.seed;
  const Eigen::MatrixXd true_torque = inverse_dynamics(robot, reference.X, c.friction);
  nlohmann::json drawn_contacts = nlohmann::json::array();
  if (c.contacts.count > 0) to.external = contact_torques(c.contacts, true_torque, c.dt, c.seed, &drawn_contacts);
  to.validate(n);  // before any output
  if (to.friction) robot.require_friction("TrackingOptions::friction");
  fs::create_directories(c.out);

  ExperimentOutcome outcome;
  std::vector<std::pair<std::string, TrackingResult>> results;
  std::vector<std::pair<std::string, std::string>> diverged;  // controller, why
  auto record = [&](const std::string& name, const std::function<TrackingResult()>& track) {
    if (progress) {
      ProgressEvent e;
      e.message = "tracking with " + name + " ...";
      progress(e);
    }
    std::string line;
    try {
      results.emplace_back(name, track());
      line = "  " + per_joint(name + " RMS error", results.back().second.rms_error);
    } catch (const Error& e) {
      // A controller that loses the robot is a result, not a reason to stop. The summary is read
      // beside this command's flags, which set the tracking options it names.
      const std::string why =
          rename_fields(e.what(), {{"TrackingOptions::bandwidth", "--bandwidth"}, {"TrackingOptions::dt", "--dt"}});
      diverged.emplace_back(name, why);
      outcome.warnings.push_back(name + ": " + why);
      line = "  " + name + ": " + why;
    }
    if (progress) {
      ProgressEvent e;
      e.message = line;
      progress(e);
    }
  };
  // Feed-forward: the model's torque along the reference, plus PD.
  auto feedforward = [&](const std::string& name, const Eigen::MatrixXd& tau) {
    record(name, [&] { return track_reference(robot, reference.X, tau, to); });
  };
  feedforward("pd-only", Eigen::MatrixXd::Zero(reference.X.rows(), n));
  feedforward("true-model", true_torque);
  for (const auto& [name, model] : models) feedforward(name, model->predict(reference.X));
  // Computed torque ("-ct"): the model asked, at the measured state, for the
  // torque of the commanded acceleration.
  auto computed_torque = [&](const std::string& name, const InverseDynamicsFunction& f) {
    record(name + "-ct", [&] { return track_computed_torque(robot, reference.X, f, to); });
  };
  computed_torque("true-model", [&](const Eigen::VectorXd& x) {
    return inverse_dynamics(robot, x.head(n), x.segment(n, n), x.tail(n), c.friction);
  });
  for (const auto& [name, model] : models) {
    const Estimator& e = *model;
    computed_torque(name, [&e](const Eigen::VectorXd& x) -> Eigen::VectorXd { return e.predict(x.transpose()).row(0).transpose(); });
  }

  const std::string tracking = (fs::path(c.out) / "tracking.csv").string();
  write_file_atomically(tracking, [&](std::ostream& o) {
    o << "controller,joint,rms_error,max_error,rms_torque\n";
    o.precision(10);
    for (const auto& [name, r] : results)
      for (int j = 0; j < n; ++j)
        o << name << "," << j + 1 << "," << r.rms_error(j) << "," << r.max_error(j) << "," << r.rms_torque(j) << "\n";
  });
  outcome.files.push_back(tracking);
  std::vector<std::string> header{"t"};
  for (const auto& [name, r] : results)
    for (int j = 0; j < n; ++j) header.push_back(name + "_e" + std::to_string(j + 1));
  Eigen::MatrixXd errors(reference.X.rows(), 1 + static_cast<Eigen::Index>(results.size()) * n);
  for (Eigen::Index k = 0; k < errors.rows(); ++k) errors(k, 0) = static_cast<double>(k) * c.dt;
  for (size_t m = 0; m < results.size(); ++m)
    errors.middleCols(1 + static_cast<Eigen::Index>(m) * n, n) = results[m].second.q - reference.X.leftCols(n);
  const std::string errors_csv = (fs::path(c.out) / "errors.csv").string();
  write_csv(errors_csv, header, errors);
  outcome.files.push_back(errors_csv);

  if (c.contacts.count > 0) {
    const std::string external_csv = (fs::path(c.out) / "external.csv").string();
    std::vector<std::string> columns{"t"};
    for (int j = 1; j <= n; ++j) columns.push_back("ext" + std::to_string(j));
    Eigen::MatrixXd external(to.external.rows(), n + 1);
    external << errors.col(0), to.external;
    write_csv(external_csv, columns, external);
    outcome.files.push_back(external_csv);
  }
  outcome.files.push_back(write_summary(c, robot, results, diverged, drawn_contacts));
  const std::string png = (fs::path(c.out) / "tracking.png").string();
  const PlotResult p = render_plot("tracking", errors_csv, png);
  if (p.ok) outcome.files.push_back(png);
  else outcome.warnings.push_back(p.message);
  outcome.units_done = static_cast<int>(results.size());
  outcome.units_failed = static_cast<int>(diverged.size());
  return outcome;
}

}  // namespace gipdyn
