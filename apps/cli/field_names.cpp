#include "field_names.hpp"

#include <cstdio>

#include "gipdyn/io/dataset.hpp"
#include "gipdyn/model/training.hpp"

namespace gipdyn::cli {

const FieldNames& cli_field_names() {
  static const FieldNames names{
      {"EstimatorOptions::robot_prior", "--robot"},
      {"TrainOptions::robot_prior", "--robot"},
      {"RobotPrior::robot", "--robot"},
      {"SearchSettings::restarts", "--restarts"},
      {"SearchSettings::min_noise_fraction", "--min-noise"},
      {"SearchSettings::threads", "--threads"},
      {"SearchSettings::start_screening_evaluations", "--start-screening"},
      {"GpOptions::warm_start_rows", "--warm-start-rows"},
      {"LagrangianOptions::warm_start_rows", "--warm-start-rows"},
      {"SearchSettings::hyperparameter_rows", "--hyperparameter-rows"},
      {"SparseOptions::hyperparameter_objective", "--hyperparameter-objective"},
      {"SparseOptions::inducing_points", "--inducing"},
      {"TrainOptions::nll_backend", "--distributed"},
      {"TeacherOptions::name", "--teacher"},
      {"TeacherOptions::states", "--teacher-states"},
      {"TeacherOptions::hyperparameter_rows", "--teacher-hyperparameter-rows"},
      {"TeacherOptions::student_hyperparameter_rows", "--student-hyperparameter-rows"},
      {"ChainIdentificationOptions::starts", "--chain-starts"},
      {"ChainIdentificationOptions::rows", "--chain-rows"},
      {"ChainIdentificationOptions::length_scale", "--chain-length-scale"},
      {kMatFileAdvice,
       "convert it to a CSV with columns q1..qn, qd1..qdn, qdd1..qddn, tau1..taun, or read it with a command that "
       "takes --mat-variable NAME (train, predict, evaluate, update, inspect, experiment real)"},
      {kFewerRowsAdvice, "train on fewer rows (a constant-step subsample: train --subsample N, experiment real --max-train N)"},
      {"NeighbourConsistencyOptions::radius", "--radius"},
      {"NeighbourConsistencyOptions::joints", "--joints"},
      {"NeighbourConsistencyOptions::min_separation_rows", "--min-separation-rows"},
      {"NeighbourConsistencyOptions::max_queries", "--max-queries"},
      {"TrackingOptions::bandwidth", "--bandwidth"},
      {"TrackingOptions::dt", "--dt"},
      {"TrackingOptions::position_noise", "--position-noise"},
      {"TrackingOptions::velocity_noise", "--velocity-noise"},
      {"TrackingOptions::friction", "--friction"},
      {"SearchSettings::gradient_tolerance_per_row", "--gradient-tolerance"},
      {"GpOptions::scaling", "--scaling"},
      {"GpOptions::mean", "--mean"},
      {"GpOptions::prior", "--prior"},
      {"HyperparameterPrior::width", "--prior-width"},
      {"OptimizerOptions::kind", "--optimizer"},
      {"OptimizerOptions::max_iterations", "--max-iter"},
      {"OptimizerOptions::lbfgs_memory", "--lbfgs-memory"},
      {"OptimizerOptions::adam_learning_rate", "--lr"},
      {"NeuralNetworkOptions::hidden", "--nn-hidden"},
      {"NeuralNetworkOptions::epochs", "--nn-epochs"},
      {"NeuralNetworkOptions::validation_fraction", "--nn-validation"},
      {"NeuralNetworkOptions::patience", "--nn-patience"},
      {"NeuralNetworkOptions::batch_size", "--nn-batch"},
      {"NeuralNetworkOptions::learning_rate", "--nn-lr"},
      {"SimulationOptions::samples", "--samples"},
      {"SimulationOptions::noise_std", "--noise"},
      {"SimulationOptions::dt", "--dt"},
      {"SimulationOptions::friction", "--friction"},
      {"SimulatedContacts::count", "--contacts"},
      {"SimulatedContacts::size", "--contact-size"},
      {"SimulatedContacts::duration", "--contact-duration"},
      {"SimulatedContacts::joint", "--contact-joint"},
      {"SimulatedContacts::bandwidth", "--contact-bandwidth"},
      {"ContactOptions::false_alarm_rate", "--false-alarm-rate"},
      {"ContactOptions::min_duration", "--min-duration"},
      {"ContactOptions::sample_time", "--dt"},
      {"ContactOptions::momentum_gain", "--momentum-gain"},
      {"ContactDetector::calibrate", "--calibration LOG"},
      {"PreprocessOptions::dt", "--dt"},
      {"PreprocessOptions::cutoff_hz", "--cutoff"},
      {"PreprocessOptions::filter_order", "--order"},
      {"PreprocessOptions::rest_velocity", "--rest-velocity"},
      {"PreprocessOptions::rest_duration", "--rest-duration"},
      {"PreprocessOptions::log_period", "--log-period"},
      {"PreprocessOptions::time_column", "--time-column"},
      {"PreprocessOptions::drop_rest", "--drop-rest"},
      {"PreprocessOptions::segment_starts", "--segment-starts"},
      {"PreprocessOptions::max_gap_steps", "--max-gap"},
      {"LogColumns::qdd", "--columns qdd"},
      {"LogColumns::qd", "--columns qd"},
      {"LogColumns::q", "--columns q"},
      {"LogColumns::tau", "--columns tau"},
      {"LogColumns", "--columns"},
      {"EstimatorOptions::name", "--model"},
      {"UpdateOptions::refit where-misfit", "update without --keep-hyperparameters"},
      {"UpdateOptions::refit", "--refit or --keep-hyperparameters"},
      {"UpdateOptions::replace", "--replace"},
      {"UpdateOptions::window", "--window"},
  };
  return names;
}

void print_warnings(const std::vector<std::string>& warnings) {
  for (const auto& w : warnings)
    std::fprintf(stderr, "gipdyn: warning: %s\n", rename_fields(w, cli_field_names()).c_str());
}

}  // namespace gipdyn::cli
