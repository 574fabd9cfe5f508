#pragma once
// A serial chain's geometry learned from a torque log, knowing only the joint
// types: the 4 DH numbers of every joint (a, alpha, d, theta) and the direction
// of gravity in the base frame. The torque is linear in the links' inertial
// parameters once the geometry is fixed, so they are solved by least squares
// inside every evaluation (variable projection), and Levenberg-Marquardt
// searches only the geometry, from seeded random starts. The fe estimator then
// learns the inertial parameters on the identified chain ("chain" in the
// estimator registry; docs/method.md section 16). Where the arm is a rigid
// serial chain, one 20 s motion pins its dynamics down this way where the GIP
// and LIP kernels, whose function spaces hold far more than serial chains, do
// not (docs/results/training.md, "A serial chain identified from one 20 s motion").
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"
#include "gipdyn/progress.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

struct ChainIdentificationOptions {
  // Random starts of the geometry search, each run to convergence on
  // screening_rows rows; most end in local minima, so many cheap ones.
  int starts = 48;
  int screening_rows = 100;
  // The refined_starts starts with the smallest residuals (all, if fewer) continue on a
  // constant-step subsample of `rows` rows (0: every row), and the smallest
  // residual there is kept. The fe estimator then uses every row.
  int refined_starts = 4;
  int rows = 300;
  // Each start draws a and d uniformly in [-length_scale, length_scale] metres
  // (alpha and theta uniformly over all angles; gravity along the first
  // joint's axis on even starts, tilted by up to 90 degrees on odd ones): the
  // size of the arm's links, roughly.
  double length_scale = 0.6;
  // Levenberg-Marquardt's cap on residual evaluations per start (finite-difference
  // Jacobians included).
  int max_evaluations = 6000;
  // Seed of the starts.
  std::uint64_t seed = 0;
  // Starts run at once (0: one per core); the result does not depend on it.
  int threads = 0;
  // Magnitude of gravity, m/s^2; its direction is learned.
  double gravity = 9.81;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

enum class ChainIdentificationStatus {
  Converged,       // the best start met Levenberg-Marquardt's stopping rules
  MaxEvaluations,  // the best start stopped at max_evaluations: usable, maybe not at its optimum
  Failed,          // no start gave a finite residual: see message
};
std::string to_string(ChainIdentificationStatus status);

struct ChainStartReport {
  double residual_rms = 0.0;  // N m (or N), on the subsample, after the inertial least squares
  int evaluations = 0;
  ChainIdentificationStatus status = ChainIdentificationStatus::Failed;
};

struct ChainIdentification {
  ChainIdentificationStatus status = ChainIdentificationStatus::Failed;
  std::string message;  // on failure
  // The identified chain: DH numbers and gravity learned, links given unit
  // placeholders (mass 1 kg, inertia 0.01 kg m^2): the torque regressor
  // depends on the geometry alone, and fe learns the inertial parameters.
  RobotModel robot;
  double residual_rms = 0.0;  // of the kept start
  long rows = 0;              // rows the geometry was refined on
  long screening_rows = 0;    // rows every start ran on
  std::vector<ChainStartReport> starts;   // on the screening rows
  std::vector<ChainStartReport> refined;  // the leaders, on `rows`
  double seconds = 0.0;

  bool ok() const { return status != ChainIdentificationStatus::Failed; }
  // A few lines: status, kept residual, the spread over the starts.
  std::string brief_report() const;
};

// X: N x 3n (q, qd, qdd), Y: N x n torques. Throws gipdyn::Error on bad data
// or options; numerical trouble is reported in the result's status.
ChainIdentification identify_chain(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                                   const ChainIdentificationOptions& options,
                                   const ProgressCallback& progress = nullptr);

}  // namespace gipdyn
