#pragma once
// Model files of every estimator: one container (io/detail/model_container.hpp,
// docs/model-format.md) whose "estimator" entry says how to read it back.
#include <memory>
#include <string>

#include "gipdyn/estimators/estimator.hpp"

namespace gipdyn {

// The model file container (io/detail/model_container.hpp, docs/model-format.md).
struct ModelContainer;

// The estimator's model file contents: to_container() and its teaching record.
ModelContainer estimator_container(const Estimator& estimator);
// Written atomically (temporary file + rename).
void save_estimator(const Estimator& estimator, const std::string& path);
// Throws gipdyn::Error for a missing, truncated, corrupted or newer-version file.
std::unique_ptr<Estimator> load_estimator(const std::string& path);
// `what` names the source in errors ("model file 'a.gipdyn'").
std::unique_ptr<Estimator> estimator_from_container(const ModelContainer& container, const std::string& what);

}  // namespace gipdyn
