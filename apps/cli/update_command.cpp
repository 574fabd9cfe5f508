// `gipdyn update`: add new samples to a trained GP model with its hyperparameters
// fixed (O(N^2) per sample; a sparse model O(M^2)), optionally as a sliding window over the newest rows (exact models),
// or in place of the model's own rows (--replace), and optionally refit the hyperparameters on the kept rows
// afterwards.
#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "data_option.hpp"
#include "output_guard.hpp"
#include "field_names.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/estimators/online_update.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn::cli {

Command add_update(CLI::App& app) {
  struct Args {
    std::string model, data, mat_variable, columns, out;
    long window = 0;
    bool quiet = false, refit = false, replace = false, keep_hyperparameters = false;
    int max_iter = OptimizerOptions{}.max_iterations, threads = 0;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--model", a->model, "GP model file from `gipdyn train` (or an earlier update)")
      ->required()->check(CLI::ExistingFile);
  add_data_option(app, a->data, a->mat_variable, a->columns, "New samples: CSV with columns q1..qn, qd1..qdn, qdd1..qddn, tau1..taun");
  app.add_option("--window", a->window,
                 "Keep only the newest this many rows (a sliding window; 0: keep every row)")
      ->capture_default_str();
  app.add_flag("--replace", a->replace,
               "Condition on the new rows alone, dropping the model's own: the hyperparameters the model learned "
               "on a long, varied log carried to a short log of the same robot, which predicts new motions better "
               "than training on the short log (docs/results/training.md)")
      ->excludes(app.get_option("--window"));
  app.add_flag("--refit", a->refit,
               "Then re-optimise the hyperparameters on all the kept rows, starting from the current ones (the "
               "periodic refit of online learning: minutes at a few thousand rows, against milliseconds per row "
               "without it)");
  app.add_flag("--keep-hyperparameters", a->keep_hyperparameters,
               "Refuse, naming the joints, where the new rows show that the hyperparameters no longer fit them "
               "(by default update then re-learns them, as --refit does)")
      ->excludes(app.get_option("--refit"));
  app.add_option("--max-iter", a->max_iter, "--refit: safety cap on NLL evaluations per joint")->capture_default_str();
  app.add_option("--threads", a->threads, "--refit: joints trained at once (0: all, sharing the cores)")->capture_default_str();
  app.add_option("--out", a->out, "Updated model file")->required();
  app.add_flag("--quiet", a->quiet, "Print nothing but errors");
  return [a]() -> int {
    refuse_overwrites({{"--model", a->model}, {"--data", a->data}}, {{"--out", a->out}});
    std::unique_ptr<Estimator> estimator = load_estimator(a->model);
    // The log is checked against the model's robot first: a log for another robot is the likelier mistake.
    const Dataset data = read_robot_log(a->data, a->mat_variable, estimator->joints(), true,
                                        "the model '" + a->model + "'", parse_log_columns(a->columns));
    require_updatable(*estimator);
    const InverseDynamicsModel* model = estimator->gp_model();
    UpdateOptions o;
    o.window = a->window;
    o.replace = a->replace;
    o.refit = a->refit ? UpdateRefit::Always : a->keep_hyperparameters ? UpdateRefit::Never : UpdateRefit::WhereMisfit;
    o.search.optimizer.max_iterations = a->max_iter;
    o.search.threads = a->threads;
    // Every joint keeps its N x N Cholesky factor while it is updated (with --replace too: the old rows are
    // dropped from the factor that holds them).
    const double rows = static_cast<double>(model->num_training_samples() + data.rows());
    require_memory(8.0 * rows * rows * (model->num_joints() + 1), "updating a model of " +
                   std::to_string(static_cast<long>(rows)) + " rows", "use --window to keep fewer rows");
    const UpdateResult r = update_estimator(*estimator, data.X, data.tau, o);
    const InverseDynamicsModel& updated = *r.estimator->gp_model();
    if (!a->quiet) {
      if (r.check) std::printf("%s", r.check->brief_report().c_str());
      if (updated.is_sparse())
        std::printf("updated %s with %ld rows of %s (hyperparameters and %d inducing rows fixed): %ld data rows\n",
                    a->model.c_str(), static_cast<long>(data.rows()), a->data.c_str(), updated.num_training_samples(),
                    static_cast<long>(updated.num_data_rows()));
      else if (a->replace)
        std::printf("conditioned the hyperparameters of %s on the %ld rows of %s alone (its own rows dropped)\n",
                    a->model.c_str(), static_cast<long>(data.rows()), a->data.c_str());
      else
        std::printf("updated %s with %ld rows of %s: %d training rows%s\n", a->model.c_str(),
                    static_cast<long>(data.rows()), a->data.c_str(), updated.num_training_samples(),
                    a->window > 0 ? (", window " + std::to_string(a->window)).c_str() : "");
      if (r.refitted)
        std::printf("%s\n%s", r.refit_start == RefitStart::DataDriven
                                   ? "the hyperparameters no longer fit the new rows: re-learned them on every row, "
                                     "from the data as a new training starts"
                                   : "re-learned the hyperparameters on every row, from the current ones",
                    r.refit_report->brief_report().c_str());
    }
    if (r.refit_report) print_warnings(r.refit_report->warnings());
    save_estimator(*r.estimator, a->out);
    if (!a->quiet) std::printf("saved %s\n", a->out.c_str());
    return 0;
  };
}

}  // namespace gipdyn::cli
