#pragma once
// Named starting points for the estimator options, for users who would rather
// not tune. Explicit options given on top of a preset override it.
//   "default"  the library's defaults: gip, maximum likelihood, no restarts.
//   "real"     for logs of real robots (docs/results/real-robots.md): the kernel
//              gip-envelope+friction (GIP bounded by an RBF envelope, which
//              keeps GIP's accuracy inside the training motions and returns to
//              the prior mean far outside them, plus each joint's smooth
//              friction and torque offset), on a constant-step subsample of at
//              most preset_max_training_rows rows.
#include <string>
#include <vector>

#include "gipdyn/estimators/fit_estimator.hpp"

namespace gipdyn {

const std::vector<std::string>& preset_names();
// Throws gipdyn::Error listing the names for an unknown one.
EstimatorOptions preset_options(const std::string& name);
// The most training rows the preset is meant for (a constant-step subsample of
// longer logs keeps the O(N^3) training in minutes); 0: every row.
int preset_max_training_rows(const std::string& name);

}  // namespace gipdyn
