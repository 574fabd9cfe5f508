#pragma once
// Is the torque a function of the logged state? A model-free check of a log
// before any training: pair rows that visit (nearly) the same state and see how
// much their torques differ. Within one log the pairs must lie apart in time,
// so that they are two visits, not neighbouring samples of one. Between a
// training log and a test log, a torque that differs at the same states far more
// than within the training log means the test log is another function of the
// state (a payload, a drifting offset, another controller), which no estimator
// of (q, qd, qdd) can learn from the training rows (docs/results/real-robots.md).
#include <Eigen/Dense>
#include <string>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

struct NeighbourConsistencyOptions {
  // Two rows are neighbours when the Euclidean distance of their standardised
  // inputs (each column divided by its standard deviation over the reference
  // rows) is at most this.
  double radius = 0.1;
  // Joint types, one R or P per joint (e.g. "RRPR"). A revolute joint's
  // positions are compared on the circle, as the kernels see them (through
  // their sine and cosine): q and q + 2 pi are one state, and a joint logged
  // within (-pi, pi] has its two sides together. Empty: positions as logged.
  std::string joints;
  // Within one log: neighbours at least this many rows apart (one second of a
  // 125 Hz log is 125).
  long min_separation_rows = 100;
  // Compare accelerations too. Off by default: logged accelerations are often
  // mostly noise (docs/results/real-robots.md), which would leave no neighbours.
  bool use_accelerations = false;
  // At most this many query rows, a constant-step subsample (cost: queries x
  // reference rows x inputs).
  long max_queries = 5000;
  // Fewer neighbour pairs than this gives Status::TooFewPairs.
  long min_pairs = 30;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

struct NeighbourConsistency {
  enum class Status { Ok, TooFewPairs };
  Status status = Status::TooFewPairs;
  std::string message;  // for TooFewPairs: why, and what to change
  long queries = 0;     // query rows searched
  long pairs = 0;       // query rows that found a neighbour
  // Per joint, over the pairs: mean (tau_query - tau_neighbour)^2 over the
  // population variance of the query torque over all queries (the scale of the
  // log's nMSE): the nMSE of predicting each paired row's torque by its
  // neighbour's. Within one log, with independent noise, about half of it is
  // the noise share. It describes the states that have neighbours: where few
  // queries do (high dimension, few rows), those are atypical and far apart.
  Eigen::VectorXd neighbour_nmse;
  Eigen::VectorXd correlation;  // per joint: of tau_query and tau_neighbour over the pairs
};

// X: N x 3n (q, qd, qdd), tau: N x n. Neighbours of rows of the log itself,
// at least options.min_separation_rows apart. Throws gipdyn::Error for
// mismatched shapes, non-finite values or bad options.
NeighbourConsistency neighbour_consistency(const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau,
                                           const NeighbourConsistencyOptions& options = {});

// Neighbours in the reference log (training) of the rows of the query log
// (test); inputs standardised by the reference rows. Row separation does not
// apply: the logs are different.
NeighbourConsistency neighbour_consistency(const Eigen::MatrixXd& reference_X, const Eigen::MatrixXd& reference_tau,
                                           const Eigen::MatrixXd& query_X, const Eigen::MatrixXd& query_tau,
                                           const NeighbourConsistencyOptions& options = {});

std::string to_string(NeighbourConsistency::Status status);  // ok, too-few-pairs

}  // namespace gipdyn
