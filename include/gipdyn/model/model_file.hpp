#pragma once
// GP model files: an InverseDynamicsModel in the model container
// (io/detail/model_container.hpp, docs/model-format.md) with "estimator": "gp".
// Files of any estimator are read by load_estimator (estimators/estimator.hpp).
#include <string>

#include "gipdyn/model/inverse_dynamics_model.hpp"

namespace gipdyn {

// The model file container (io/detail/model_container.hpp, docs/model-format.md).
struct ModelContainer;

// Written atomically (temporary file + rename).
void save_model(const InverseDynamicsModel& model, const std::string& path);

// Throws gipdyn::Error for a missing, truncated, corrupted or newer-version
// file, or one that holds a non-GP estimator.
InverseDynamicsModel load_model(const std::string& path);

// The same format in memory (used for pickling); `what` names the source in errors.
std::string serialize_model(const InverseDynamicsModel& model);
InverseDynamicsModel deserialize_model(const std::string& bytes, const std::string& what = "model data");

ModelContainer model_to_container(const InverseDynamicsModel& model);
InverseDynamicsModel model_from_container(const ModelContainer& container, const std::string& what);

}  // namespace gipdyn
