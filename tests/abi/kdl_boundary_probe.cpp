// The KDL boundary (src/robot: robot models, URDF loading, KDL's recursive
// Newton-Euler) compiled for another instruction set than the library's, as
// GIPDYN_NATIVE compiles it on another CPU, and run. Every Eigen object that
// crosses into Debian's liborocos-kdl must keep working there: a layout that
// differs from KDL's crashes or corrupts the heap on these paths.
//
//   kdl_boundary_probe ROBOTS_DIR     (examples/robots: a URDF and a DH file)
//
// Exit 0 when KDL's torques equal the regressor's on every robot, 1 otherwise.
#include <kdl/jntarray.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include <nlohmann/json.hpp>

namespace {

// KDL allocates a JntArray's storage, this file's Eigen resizes, writes and
// frees it, and KDL's destructor frees the last block: both sides must use one
// heap convention.
bool jnt_arrays_survive_resizing() {
  double sum = 0.0;
  for (int i = 0; i < 2000; ++i) {
    KDL::JntArray a(4);
    a.data.resize(5 + i % 7);
    a.data.setConstant(1.0);
    KDL::JntArray b(3);
    b.data = a.data;
    sum += b.data.sum();
  }
  return std::isfinite(sum) && sum > 0.0;
}

// Largest relative difference between KDL's torques and the regressor's (Phi w)
// over random states of the robot, with friction.
double worst_disagreement(const gipdyn::RobotModel& robot, std::uint64_t seed) {
  const int n = robot.num_joints();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd w(12 * n);
  w << robot.inertial_parameters(), robot.friction_parameters();
  Eigen::MatrixXd X(200, 3 * n);
  for (Eigen::Index r = 0; r < X.rows(); ++r)
    for (Eigen::Index c = 0; c < X.cols(); ++c) X(r, c) = 2.0 * u(rng);
  const Eigen::MatrixXd tau = gipdyn::inverse_dynamics(robot, X, true);
  double worst = 0.0;
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const Eigen::VectorXd q = X.row(r).segment(0, n).transpose(), qd = X.row(r).segment(n, n).transpose(),
                          qdd = X.row(r).segment(2 * n, n).transpose();
    const Eigen::VectorXd by_regressor = gipdyn::regressor(robot, q, qd, qdd, true) * w;
    worst = std::max(worst, (tau.row(r).transpose() - by_regressor).norm() / (1.0 + tau.row(r).norm()));
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: kdl_boundary_probe ROBOTS_DIR\n");
    return 2;
  }
  try {
    const std::string dir = argv[1];
    bool ok = jnt_arrays_survive_resizing();
    std::printf("KDL::JntArray storage resized and freed across the boundary: %s\n", ok ? "ok" : "FAILED");
    const gipdyn::RobotModel urdf = gipdyn::load_robot_urdf(dir + "/panda_like.urdf");
    const std::vector<gipdyn::RobotModel> robots = {
        gipdyn::scara_robot(), gipdyn::ur10_robot(), gipdyn::load_robot_json(dir + "/puma560.json"), urdf,
        gipdyn::robot_from_storable_json(gipdyn::robot_to_storable_json(urdf), "the stored URDF")};
    std::uint64_t seed = 1;
    for (const gipdyn::RobotModel& robot : robots) {
      const double worst = worst_disagreement(robot, seed++);
      const bool agrees = worst < 1e-9;
      ok = ok && agrees;
      std::printf("%-12s KDL against the regressor: largest relative difference %.2e  %s\n", robot.name().c_str(),
                  worst, agrees ? "ok" : "FAILED");
    }
    return ok ? 0 : 1;
  } catch (const gipdyn::Error& e) {
    std::fprintf(stderr, "kdl_boundary_probe: %s\n", e.what());
    return 1;
  }
}
