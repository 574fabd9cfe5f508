#pragma once
// The model file: one self-contained, versioned, checksummed file holding
// everything prediction needs. Layout (docs/model-format.md):
//
//   8 bytes  magic "GIPDYNMF"
//   u32      format version (kModelFormatVersion)
//   u32      reserved (0)
//   u64      header length H
//   H bytes  JSON header: joints, kernel, output scaling, per-joint log-hyperparameters,
//            noise, jitter, NLL, and the list of binary arrays that follow
//   ...      arrays of little-endian IEEE-754 doubles, column-major, in header order
//   u64      FNV-1a 64 checksum of every preceding byte
#include <string>

#include "gipdyn/model/inverse_dynamics_model.hpp"

namespace gipdyn {

constexpr unsigned kModelFormatVersion = 1;

// Written atomically (temporary file + rename).
void save_model(const InverseDynamicsModel& model, const std::string& path);

// Throws gipdyn::Error for a missing, truncated, corrupted or newer-version file.
InverseDynamicsModel load_model(const std::string& path);

// The same format in memory (used for pickling); `what` names the source in errors.
std::string serialize_model(const InverseDynamicsModel& model);
InverseDynamicsModel deserialize_model(const std::string& bytes, const std::string& what = "model data");

}  // namespace gipdyn
