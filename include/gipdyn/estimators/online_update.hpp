#pragma once
// Updating a fitted model with new rows: the rule every front end follows.
// A GP model is conditioned on the new rows with its hyperparameters fixed
// (InverseDynamicsModel::updated), after a check that those hyperparameters
// still fit them (UpdateCheck): where they do not, the update re-learns them,
// or refuses, as UpdateOptions::refit says. A taught model is refused: its rows
// are its teacher's drawn states, not the log, and mixing log rows into them
// does not give what a training on the whole log gives.
#include <Eigen/Dense>
#include <memory>
#include <optional>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/model/update_check.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

enum class UpdateRefit {
  WhereMisfit,  // re-learn the hyperparameters (from the data-driven start) where the check fails
  Always,       // re-learn them from the current ones, whatever the check says
  Never,        // keep them: refuse, naming the joints, where the check fails
};
UpdateRefit parse_update_refit(const std::string& name);  // where-misfit | always | never
std::string to_string(UpdateRefit refit);

struct UpdateOptions {
  Eigen::Index window = 0;  // keep the newest this many rows (0: every row)
  bool replace = false;     // condition on the new rows alone (exact models)
  UpdateRefit refit = UpdateRefit::WhereMisfit;
  SearchSettings search;    // the refit's optimiser, threads
  void validate() const;    // throws gipdyn::Error naming the field
};

struct UpdateResult {
  std::unique_ptr<Estimator> estimator;  // the updated model, with the records of the one it came from
  std::optional<UpdateCheck> check;      // exact models: the check made before conditioning
  bool refitted = false;
  RefitStart refit_start = RefitStart::CurrentHyperparameters;
  std::optional<FitReport> refit_report;
};

// Throws gipdyn::Error, naming the fix, for a model that takes no new rows: one
// that is not a per-joint GP, or a taught one. Front ends call it before they
// read the new rows; update_estimator calls it too.
void require_updatable(const Estimator& estimator);

// Throws gipdyn::Error (before any work) for a model require_updatable refuses, rows of another width, a window or replace a sparse model
// cannot honour, and, with UpdateRefit::Never, for new rows the hyperparameters
// no longer fit (UpdateCheck::warning); a refit that fails throws with its message.
UpdateResult update_estimator(const Estimator& estimator, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                              const UpdateOptions& options, const ProgressCallback& progress = {});

}  // namespace gipdyn
