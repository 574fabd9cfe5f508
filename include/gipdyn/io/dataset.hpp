#pragma once
// Datasets in the documented CSV layout: columns q1..qn, qd1..qdn, qdd1..qddn,
// and for training/evaluation tau1..taun, in any order; tau1_true..taun_true
// (noise-free torques from `gipdyn simulate`) are read when present; other
// columns are ignored.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

struct Dataset {
  Eigen::MatrixXd X;         // N x 3n: q, qd, qdd
  Eigen::MatrixXd tau;       // N x n (empty if not read)
  Eigen::MatrixXd tau_true;  // N x n (empty if the file has no *_true columns)
  Eigen::MatrixXd external_true;  // N x n: ext1_true.. (simulate --contacts); empty if the file has none
  Eigen::Index rows() const { return X.rows(); }
  Dataset subset(const std::vector<Eigen::Index>& rows) const;
};

// The advice read_dataset gives for a MATLAB file; front ends rename it to their own.
extern const char* const kMatFileAdvice;

// How many joints the header's position columns name: n where q1..qn are there and q(n+1) is not.
int joint_column_count(const CsvHeader& header);

// Throws gipdyn::Error when the file's joint columns q1, q2, ... (counted from 1) are not those
// of joints. joints_owner names where fixed joint types come from (e.g. "the model 'm.gipdyn'"),
// so that the error asks for the right file instead of other joint types; empty: the caller
// chose them.
void require_joint_columns(const CsvHeader& header, const std::string& path, const JointTypes& joints,
                           const std::string& joints_owner = "");

// The joint types a log's sidecar (PATH.json beside the CSV, written by
// write_csv_with_sidecar) records as a string under "joints", e.g. "RRPR"
// (simulate writes it): nullopt without a sidecar or without such a string
// (preprocess records a joint count there). Throws gipdyn::Error naming the
// sidecar when it is not valid JSON or its string is not joint types.
std::optional<JointTypes> sidecar_joint_types(const std::string& path);

// What wrote the log, as its sidecar records under "generator" (simulate:
// kSimulationGenerator, gipdyn/sim/simulate.hpp): nullopt without a sidecar,
// without such a string, or where the sidecar is not valid JSON (a hint, not a
// check: sidecar_joint_types reports a broken sidecar).
std::optional<std::string> sidecar_generator(const std::string& path);

// The rows' sampling period in seconds, as the log's sidecar records it
// (simulate: "dt"; preprocess: "dt_s"): nullopt without a sidecar, without
// such a positive number, or where the sidecar is not valid JSON.
std::optional<double> sidecar_sample_time(const std::string& path);

// Throws gipdyn::Error for a MATLAB file, a missing column, a joint count that does not match
// the file (e.g. joints RRPR on a file with q5; joints_owner as above), bad cells or no rows.
// `columns`: what the log calls q1.., qd1.., qdd1.., tau1.. (LogColumns).
Dataset read_dataset(const std::string& path, const JointTypes& joints, bool require_tau,
                     const std::string& joints_owner = "", const LogColumns& columns = {});

}  // namespace gipdyn
