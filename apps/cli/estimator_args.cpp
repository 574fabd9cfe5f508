#include "estimator_args.hpp"

#include "cli_parsing.hpp"
#include <algorithm>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/presets.hpp"
#include "gipdyn/robot/robot_loader.hpp"

namespace gipdyn::cli {

std::string estimator_list() {
  return joined(estimator_names());
}

std::string estimator_table_text() {
  size_t width = 0;
  for (const EstimatorSpec& e : estimator_table()) width = std::max(width, e.name.size());
  std::string text = "Models (--model):\n";
  for (const EstimatorSpec& e : estimator_table())
    text += "  " + e.name + std::string(width + 2 - e.name.size(), ' ') + e.help +
            (e.needs_robot ? " (needs --robot)" : "") + "\n";
  return text;
}

std::string preset_list() {
  std::vector<std::string> clauses;
  for (const std::string& name : preset_names()) {
    const int rows = preset_max_training_rows(name);
    clauses.push_back(name + " (" + preset_options(name).name +
                      (rows > 0 ? ", at most " + std::to_string(rows) + " rows" : std::string()) + ")");
  }
  return joined(clauses);
}

void EstimatorArgs::add_to(CLI::App& app, bool with_robot, bool with_seed) {
  // The model-based estimators' robot first: it chooses a model, the advanced groups after it only search.
  if (with_robot) {
    app.add_option("--robot", robot,
                   "Nominal robot for the model-based estimators fe, pp, sp: scara, ur10, a URDF or a JSON DH file")
      ->group(kRobotOptions);
    app.add_flag("--robot-friction", robot_friction,
                 "fe, pp, sp: add viscous and Coulomb friction parameters to the rigid-body regressor")
      ->group(kRobotOptions);
  }
  app.add_option("--optimizer", optimizer, "GP hyperparameter optimiser: lbfgs or adam")->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--max-iter", max_iter,
                 "GP: safety cap on NLL evaluations (L-BFGS) or steps (Adam) per joint, start and stage")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--lbfgs-memory", lbfgs_memory,
                 "GP: correction pairs L-BFGS keeps (docs/results/training.md compares memories)")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--gradient-tolerance", gradient_tolerance,
                 "GP: converged when the projected NLL gradient (max over log-hyperparameters) per training row "
                 "is at most this")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--warm-start-rows", warm_start_rows,
                 "GP and lip: optimise first (every start and restart) on a constant-step subsample of this many "
                 "rows, then the best on all rows; 0: off")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--inducing", inducing,
                 "GP: sparse GP with this many inducing rows chosen among the training rows (variational bound, "
                 "O(N M^2) per evaluation: for logs too long for the exact GP); 0: exact")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--hyperparameter-rows", hyperparameter_rows,
                 "GP: learn the hyperparameters on a constant-step subsample of this many rows, then condition "
                 "the model on every row (with --inducing: 10^6 rows in minutes); 0: all rows")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--hyperparameter-objective", hyperparameter_objective,
                 "GP with --inducing and --hyperparameter-rows: what the hyperparameters minimise on the "
                 "subsample, bound (the sparse GP's variational bound) or exact (the subsample's exact NLL, "
                 "O(rows^3) per evaluation; docs/method.md section 14)")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--lr", learning_rate, "GP: Adam learning rate")->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--restarts", restarts,
                 "GP: extra optimiser runs from perturbed starts; the best NLL is kept (default: the model's own: " +
                     restart_defaults_summary() + ")")
      ->type_name("INT")
      ->group(kGpOptions);
  if (with_seed)
    app.add_option("--seed", seed, "Seed for GP restarts and the network's initialisation and batches")
        ->capture_default_str();
  app.add_option("--scaling", scaling, "GP: output scaling before the GP: none, center or standardize")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--mean", mean,
                 "GP: prior mean of each joint's GP, trained with the kernel: zero (as the paper), constant, or "
                 "linear in (q, qd, qdd)")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--min-noise", min_noise, "GP: noise-variance floor, as a fraction of the scaled output variance")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--prior", prior,
                 "GP: none (maximum likelihood) or lognormal (MAP: each log-hyperparameter ~ N(its data-driven "
                 "start, width^2))")
      ->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--prior-width", prior_width, "GP: standard deviation of the log-normal priors")->capture_default_str()
      ->group(kGpOptions);
  app.add_option("--threads", threads, "GP: joints trained at once; lip: starts run at once (0: all, sharing the cores; results do not depend on it)")->capture_default_str();
  app.add_flag("--no-serial-chain", no_serial_chain,
               "lip (and the lip teacher): the joints are not ordered from the base to the tip of one serial "
               "chain, so let every entry of the inertia matrix depend on every joint (the LIP paper's kernel; "
               "by default entry ab depends only on the joints after min(a, b), docs/method.md section 11)")
      ->group(kLipOptions);
  app.add_option("--start-screening", start_screening,
                 "lip (and the lip teacher), and a GP's --restarts: every start first runs at most this many NLL "
                 "evaluations, then only the one with the lowest NLL continues to convergence (0: every start runs "
                 "to convergence; docs/training.md; default: the model's own: " + start_screening_defaults_summary() + ")")
      ->type_name("INT")
      ->group(kLipOptions);
  app.add_option("--chain-starts", chain.starts,
                 "chain: random starts of the geometry search (DH numbers and gravity direction); the smallest "
                 "residual is kept")
      ->capture_default_str()
      ->group(kChainOptions);
  app.add_option("--chain-rows", chain.rows,
                 "chain: the geometry is searched on a constant-step subsample of this many rows (0: all), then fe "
                 "learns the inertial parameters on every row")
      ->capture_default_str()
      ->group(kChainOptions);
  app.add_option("--chain-length-scale", chain.length_scale,
                 "chain: starts draw the DH lengths a and d in +-this many metres (roughly the arm's link length)")
      ->capture_default_str()
      ->group(kChainOptions);
  app.add_option("--nn-hidden", nn_hidden, "nn: hidden layer widths, e.g. 400,400 (default: 400,400; 600,600 for 6+ joints)")
      ->group(kNetworkOptions);
  app.add_option("--nn-epochs", nn.epochs, "nn: the most training epochs (fewer where the held-out loss stops falling)")
      ->capture_default_str()
      ->group(kNetworkOptions);
  app.add_option("--nn-batch", nn.batch_size, "nn: minibatch size")->capture_default_str()
      ->group(kNetworkOptions);
  app.add_option("--nn-lr", nn.learning_rate, "nn: Adam learning rate")->capture_default_str()
      ->group(kNetworkOptions);
  app.add_option("--nn-validation", nn.validation_fraction,
                 "nn: share of the rows held out for early stopping, as stretches of consecutive rows spread over "
                 "the log (0: train on every row for all the epochs)")
      ->capture_default_str()
      ->group(kNetworkOptions);
  app.add_option("--nn-patience", nn.patience, "nn: stop after this many epochs without a lower held-out loss")
      ->capture_default_str()
      ->group(kNetworkOptions);
}

RobotPrior EstimatorArgs::robot_prior() const {
  RobotPrior prior;
  if (!robot.empty()) prior.robot = std::make_shared<const RobotModel>(load_robot(robot));
  prior.friction = robot_friction;
  return prior;
}

EstimatorOptions EstimatorArgs::build(const std::string& name) const {
  EstimatorOptions o;
  o.name = name;
  o.gp.keep_factor = false;
  return overlay(o, nullptr);
}

EstimatorOptions EstimatorArgs::build_over(const EstimatorOptions& base, const CLI::App& app,
                                           const std::string& name, bool given_name) const {
  EstimatorOptions o = base;
  if (given_name) o.name = name;
  o.gp.keep_factor = false;
  return overlay(o, &app);
}

EstimatorOptions EstimatorArgs::overlay(EstimatorOptions o, const CLI::App* app) const {
  // Without an app every option is taken; with one, only those given on its command line.
  auto given = [app](const char* flag) {
    return !app || (app->get_option_no_throw(flag) != nullptr && app->count(flag) > 0);
  };
  if (given("--optimizer")) o.search.optimizer.kind = parse_optimizer(optimizer);
  if (given("--max-iter")) o.search.optimizer.max_iterations = max_iter;
  if (given("--lbfgs-memory")) o.search.optimizer.lbfgs_memory = lbfgs_memory;
  if (given("--lr")) o.search.optimizer.adam_learning_rate = learning_rate;
  if (given("--restarts") && restarts) o.search.restarts = *restarts;  // unset: the model's own
  if (given("--warm-start-rows")) o.gp.warm_start_rows = warm_start_rows;
  if (given("--inducing")) o.sparse.inducing_points = inducing;
  if (given("--hyperparameter-rows")) o.search.hyperparameter_rows = hyperparameter_rows;
  if (given("--hyperparameter-objective"))
    o.sparse.hyperparameter_objective = parse_hyperparameter_objective(hyperparameter_objective);
  if (given("--gradient-tolerance")) o.search.gradient_tolerance_per_row = gradient_tolerance;
  if (given("--seed")) o.set_seed(seed);
  if (given("--scaling")) o.gp.scaling = parse_output_scaling(scaling);
  if (given("--mean")) o.gp.mean = parse_mean_kind(mean);
  if (given("--min-noise")) o.search.min_noise_fraction = min_noise;
  if (given("--threads")) {
    o.search.threads = threads;
    o.chain.threads = threads;
  }
  if (given("--chain-starts")) o.chain.starts = chain.starts;
  if (given("--chain-rows")) o.chain.rows = chain.rows;
  if (given("--chain-length-scale")) o.chain.length_scale = chain.length_scale;
  if (given("--no-serial-chain")) o.serial_chain = !no_serial_chain;
  if (given("--start-screening") && start_screening) o.search.start_screening_evaluations = *start_screening;
  if (given("--prior") || given("--prior-width")) o.gp.prior = parse_hyperparameter_prior(prior, prior_width);
  if (given("--nn-epochs")) o.nn.epochs = nn.epochs;
  if (given("--nn-batch")) o.nn.batch_size = nn.batch_size;
  if (given("--nn-lr")) o.nn.learning_rate = nn.learning_rate;
  if (given("--nn-validation")) o.nn.validation_fraction = nn.validation_fraction;
  if (given("--nn-patience")) o.nn.patience = nn.patience;
  if (!nn_hidden.empty()) o.nn.hidden = parse_int_list(nn_hidden, "--nn-hidden", "400,400");
  if (estimator_needs_robot(o.name)) o.robot_prior = robot_prior();
  return o;
}

}  // namespace gipdyn::cli
