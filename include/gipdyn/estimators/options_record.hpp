#pragma once
// What a model was trained with: the EstimatorOptions a front end sets, as the
// model file's "options" block (docs/model-format.md). With it a loaded model
// can be trained again the same way, and Python's load() gives back the
// parameters that made it. Not recorded: the nominal robot (a model that needs
// one holds it), the threads and the likelihood backend (neither changes the
// model), and the teacher's own settings (the "teacher" block has them).
#include <nlohmann/json_fwd.hpp>

#include "gipdyn/estimators/fit_estimator.hpp"

namespace gipdyn {

nlohmann::json options_record(const EstimatorOptions& options);

// The options a record holds, over the defaults for what it lacks (a record
// written by an older gipdyn). Throws gipdyn::Error naming the field of a value
// that is not of its type or not a valid choice.
EstimatorOptions options_from_record(const nlohmann::json& record);

}  // namespace gipdyn
