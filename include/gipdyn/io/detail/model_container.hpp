#pragma once
// The container every gipdyn model file uses, whatever the estimator
// (docs/model-format.md):
//
//   8 bytes  magic "GIPDYNMF"
//   u32      format version (kModelFormatVersion)
//   u32      reserved (0)
//   u64      header length H
//   H bytes  JSON header; its "arrays" entry lists {name, rows, cols} of the arrays that follow
//   ...      arrays of little-endian IEEE-754 doubles, column-major, in header order
//   u64      FNV-1a 64 checksum of every preceding byte
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

// 3: sparse GP models ("approximation": "vfe"). Older versions are read as they are.
constexpr unsigned kModelFormatVersion = 3;

struct ModelContainer {
  nlohmann::json header;  // without "arrays", "format", "format_version": pack_container writes those
  std::vector<std::pair<std::string, Eigen::MatrixXd>> arrays;

  void add(std::string name, Eigen::MatrixXd value) { arrays.emplace_back(std::move(name), std::move(value)); }
  // Throws gipdyn::Error ("... is corrupted (no array 'name')") when absent; `what` names the source.
  const Eigen::MatrixXd& array(const std::string& name, const std::string& what) const;
};

// Throws gipdyn::Error, naming the array or header field, where a number is NaN or Inf: JSON cannot
// hold one, and no model of ours needs one (a missing number is a null: io/detail/json_numbers.hpp).
std::string pack_container(const ModelContainer& container);
// Throws gipdyn::Error naming `what` for bad magic, a newer version, truncation or a checksum mismatch.
ModelContainer unpack_container(const std::string& bytes, const std::string& what);

// Whole-file helpers: the write is atomic (temporary file + rename), and writes nothing where
// pack_container would throw.
void write_container(const ModelContainer& container, const std::string& path);
std::string read_model_bytes(const std::string& path);

}  // namespace gipdyn
