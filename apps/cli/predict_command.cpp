// `gipdyn predict`: torques (and, for GP and lip models, standard deviations) for a CSV of states.
#include <memory>

#include "commands.hpp"
#include "data_option.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/uncertainty.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/io/mat_dataset.hpp"

namespace gipdyn::cli {

Command add_predict(CLI::App& app) {
  struct Args {
    std::string model, data, mat_variable, columns, out;
    bool no_std = false;
  };
  auto a = std::make_shared<Args>();
  app.add_option("--model", a->model, "Model file from `gipdyn train`")->required()->check(CLI::ExistingFile);
  add_data_option(app, a->data, a->mat_variable, a->columns, "States: CSV with columns q1..qn, qd1..qdn, qdd1..qddn (others ignored)");
  app.add_option("--out", a->out,
                 "Output CSV: tau1_hat..taun_hat, and tau1_std..taun_std for GP and lip models")->required();
  app.add_flag("--no-std", a->no_std, "Skip the standard deviations (much faster for large models)");
  return [a]() -> int {
    refuse_overwrites({{"--model", a->model}, {"--data", a->data}}, {{"--out", a->out}});
    std::unique_ptr<Estimator> estimator = load_estimator(a->model);
    const Dataset data = read_robot_log(a->data, a->mat_variable, estimator->joints(), false, "the model '" + a->model + "'", parse_log_columns(a->columns));
    const int n = estimator->joints().size();
    Eigen::MatrixXd mean, sd;
    std::vector<std::string> header = torque_column_names(n, "_hat");
    if (a->no_std || !estimator->gives_uncertainty()) {
      write_csv(a->out, header, estimator->predict(data.X));
    } else {
      mean = estimator->predict(data.X);
      sd = TorqueUncertainty(*estimator).latent_std(data.X);
      const auto std_names = torque_column_names(n, "_std");
      header.insert(header.end(), std_names.begin(), std_names.end());
      Eigen::MatrixXd both(mean.rows(), 2 * n);
      both << mean, sd;
      write_csv(a->out, header, both);
    }
    // After the file: a prediction that failed (non-finite) has its own one-line error.
    warn_about_extrapolation(*estimator, data.X, a->data);
    return 0;
  };
}

}  // namespace gipdyn::cli
