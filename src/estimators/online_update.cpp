#include "gipdyn/estimators/online_update.hpp"

#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"

namespace gipdyn {

UpdateRefit parse_update_refit(const std::string& name) {
  if (name == "where-misfit") return UpdateRefit::WhereMisfit;
  if (name == "always") return UpdateRefit::Always;
  if (name == "never") return UpdateRefit::Never;
  throw Error("UpdateOptions::refit must be where-misfit, always or never, got '" + name + "'");
}

std::string to_string(UpdateRefit refit) {
  switch (refit) {
    case UpdateRefit::WhereMisfit: return "where-misfit";
    case UpdateRefit::Always: return "always";
    case UpdateRefit::Never: return "never";
  }
  return "where-misfit";
}

void UpdateOptions::validate() const {
  if (window < 0) throw Error("UpdateOptions::window must be >= 0 (0: keep every row)");
  if (replace && window > 0) throw Error("UpdateOptions::replace keeps the new rows alone: leave UpdateOptions::window at 0");
}

void require_updatable(const Estimator& estimator) {
  if (!estimator.gp_model())
    throw Error("a " + estimator.name() + " model cannot be updated: only per-joint GP models take new rows; train it "
                "again on every row");
  if (const nlohmann::json* taught = estimator.teaching_record();
      taught && taught->value("outcome", std::string()) == to_string(TeachingOutcome::Taught))
    throw Error("this model was taught by " + taught->value("estimator", std::string("a teacher")) +
                ": its rows are the teacher's drawn states, not the log, and new logged rows mixed into them do not "
                "give what a training on the whole log gives; train again on every row (the old log and the new)");
}

UpdateResult update_estimator(const Estimator& estimator, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                              const UpdateOptions& options, const ProgressCallback& progress) {
  options.validate();
  require_updatable(estimator);
  const InverseDynamicsModel* model = estimator.gp_model();
  if (options.replace && model->is_sparse())
    throw Error("UpdateOptions::replace needs an exact GP model: a sparse model's inducing rows come from its own "
                "data (train the sparse model on the new rows instead)");
  if (options.replace && X.rows() < kMinTrainingRows)
    throw Error("UpdateOptions::replace: the new rows are " + std::to_string(X.rows()) + "; a model needs at least " +
                std::to_string(kMinTrainingRows));
  UpdateResult result;
  bool refit = options.refit == UpdateRefit::Always;
  // One factorisation serves the check and the update: a loaded exact model has none yet.
  InverseDynamicsModel factored = model->is_sparse() || model->has_variance() ? *model : model->with_variance();
  if (!model->is_sparse()) {
    result.check = check_update(factored, X, Y);
    if (!result.check->passed()) {
      if (options.refit == UpdateRefit::Never)
        throw Error(result.check->warning() + "; re-learn them (UpdateOptions::refit where-misfit), or train on "
                    "every row");
      if (options.refit == UpdateRefit::WhereMisfit) {
        refit = true;
        result.refit_start = RefitStart::DataDriven;
      }
    }
  }
  InverseDynamicsModel updated = std::move(factored).updated(X, Y, options.replace ? X.rows() : options.window);
  if (refit) {
    TrainOptions o;
    o.search = options.search;
    o.gp.keep_factor = false;
    TrainResult r = refit_model(updated, o, progress, result.refit_start);
    if (!r.report.ok()) throw Error("the refit of the hyperparameters failed: " + r.report.message);
    result.refit_report = r.report;
    result.refitted = true;
    updated = std::move(r.model);
  }
  auto out = std::make_unique<GpEstimator>(std::move(updated));
  // What made the model stays with it: its choice among candidates.
  if (const nlohmann::json* record = estimator.selection_record()) out->set_selection_record(*record);
  if (const nlohmann::json* record = estimator.teaching_record()) out->set_teaching_record(*record);
  if (const nlohmann::json* record = estimator.options_record()) out->set_options_record(*record);
  result.estimator = std::move(out);
  return result;
}

}  // namespace gipdyn
