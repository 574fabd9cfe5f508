#include "gipdyn/io/dataset.hpp"

#include <fstream>
#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"
#include "gipdyn/io/csv.hpp"

namespace gipdyn {

const char* const kMatFileAdvice =
    "read it with read_mat_dataset, naming the variable that holds its q, qd, qdd, tau columns, or convert it to CSV";

Dataset Dataset::subset(const std::vector<Eigen::Index>& idx) const {
  Dataset d;
  d.X = X(idx, Eigen::all);
  if (tau.size()) d.tau = tau(idx, Eigen::all);
  if (tau_true.size()) d.tau_true = tau_true(idx, Eigen::all);
  if (external_true.size()) d.external_true = external_true(idx, Eigen::all);
  return d;
}

int joint_column_count(const CsvHeader& header) {
  int n = 0;
  while (header.has("q" + std::to_string(n + 1))) ++n;
  return n;
}

void require_joint_columns(const CsvHeader& header, const std::string& path, const JointTypes& joints,
                           const std::string& joints_owner) {
  require_joints_counted_from_one(header, path);
  const int n = joints.size();
  const int file_joints = joint_column_count(header);
  if (file_joints == n || file_joints == 0) return;  // no q1 at all: the missing-column error says more
  const std::string found = "'" + path + "' has joint columns q1..q" + std::to_string(file_joints);
  if (joints_owner.empty())
    throw Error(found + " but the joint types " + joints.str() + " name " + std::to_string(n) +
                " joints; pass a joint string of length " + std::to_string(file_joints));
  throw Error(found + " but " + joints_owner + " is for " + std::to_string(n) + " joints (" + joints.str() +
              "); give it a file of the same robot: joint columns q1..q" + std::to_string(n));
}

Dataset read_dataset(const std::string& path, const JointTypes& joints, bool require_tau,
                     const std::string& joints_owner, const LogColumns& columns) {
  const int n = joints.size();
  if (std::ifstream probe(path, std::ios::binary); probe) {
    char magic[6] = {};
    probe.read(magic, sizeof magic);
    if (std::string(magic, sizeof magic) == "MATLAB")
      throw Error("'" + path + "' is a MATLAB .mat file, not a CSV; " + kMatFileAdvice);
  }
  const CsvHeader header = read_csv_header(path, columns);
  require_joint_columns(header, path, joints, joints_owner);
  Dataset d;
  std::vector<std::string> cols = input_column_names(n);
  const auto tau_cols = torque_column_names(n);
  const auto true_cols = torque_column_names(n, "_true");
  const bool has_true = header.has(true_cols.front());
  if (require_tau) cols.insert(cols.end(), tau_cols.begin(), tau_cols.end());
  if (require_tau && has_true) cols.insert(cols.end(), true_cols.begin(), true_cols.end());
  const auto external_cols = external_torque_column_names(n, "_true");
  const bool has_external = require_tau && header.has(external_cols.front());
  if (has_external) cols.insert(cols.end(), external_cols.begin(), external_cols.end());
  const Eigen::MatrixXd all = read_csv_columns(path, cols, columns);
  if (all.rows() == 0) throw Error("'" + path + "' has a header but no data rows");
  d.X = all.leftCols(3 * n);
  if (require_tau) d.tau = all.middleCols(3 * n, n);
  if (require_tau && has_true) d.tau_true = all.middleCols(4 * n, n);
  if (has_external) d.external_true = all.rightCols(n);
  return d;
}

namespace {

// The sidecar PATH.json beside a log, parsed without throwing (is_discarded()
// where it is not JSON); nullopt without a sidecar.
std::optional<nlohmann::json> read_sidecar(const std::string& path) {
  std::ifstream in(path + ".json");
  if (!in) return std::nullopt;
  return nlohmann::json::parse(in, nullptr, false);
}

// The string a sidecar records under `key`; nullopt where it records none (or is not JSON).
std::optional<std::string> recorded_string(const nlohmann::json& meta, const char* key) {
  if (!meta.is_object() || !meta.contains(key) || !meta[key].is_string()) return std::nullopt;
  return meta[key].get<std::string>();
}

}  // namespace

std::optional<JointTypes> sidecar_joint_types(const std::string& path) {
  const std::optional<nlohmann::json> meta = read_sidecar(path);
  if (!meta) return std::nullopt;
  const std::string sidecar = path + ".json";
  const auto fix = "repair or delete it, or give the joint types yourself";
  if (meta->is_discarded()) throw Error("the sidecar '" + sidecar + "' of '" + path + "' is not valid JSON; " + fix);
  const std::optional<std::string> joints = recorded_string(*meta, "joints");
  if (!joints) return std::nullopt;
  try {
    return JointTypes::parse(*joints);
  } catch (const Error& e) {
    throw Error("the sidecar '" + sidecar + "' of '" + path + "' records bad joint types: " + e.what() + "; " + fix);
  }
}

std::optional<std::string> sidecar_generator(const std::string& path) {
  const std::optional<nlohmann::json> meta = read_sidecar(path);
  return meta ? recorded_string(*meta, "generator") : std::nullopt;
}

std::optional<double> sidecar_sample_time(const std::string& path) {
  const std::optional<nlohmann::json> meta = read_sidecar(path);
  if (!meta || !meta->is_object()) return std::nullopt;
  for (const char* key : {"dt", "dt_s"})
    if (meta->contains(key) && (*meta)[key].is_number() && (*meta)[key].get<double>() > 0.0)
      return (*meta)[key].get<double>();
  return std::nullopt;
}

}  // namespace gipdyn
