#include "gipdyn/estimators/options_record.hpp"

#include <nlohmann/json.hpp>
#include <string>

#include "gipdyn/error.hpp"
#include "gipdyn/gp/hyperparameter_prior.hpp"
#include "gipdyn/gp/mean_function.hpp"

namespace gipdyn {

nlohmann::json options_record(const EstimatorOptions& o) {
  const SearchSettings s = estimator_search(o.name, o.search);  // the starts the fit ran
  return {
      {"estimator", o.name},
      {"search",
       {{"optimizer", to_string(s.optimizer.kind)},
        {"max_iterations", s.optimizer.max_iterations},
        {"lbfgs_memory", s.optimizer.lbfgs_memory},
        {"adam_learning_rate", s.optimizer.adam_learning_rate},
        {"gradient_tolerance_per_row", s.gradient_tolerance_per_row},
        {"restarts", s.restart_count()},
        {"restart_spread", s.restart_spread_or_default()},
        {"seed", s.seed},
        {"start_screening_evaluations", s.start_screening_or_default()},
        {"hyperparameter_rows", s.hyperparameter_rows},
        {"min_noise_fraction", s.min_noise_fraction}}},
      {"gp",
       {{"scaling", to_string(o.gp.scaling)},
        {"mean", to_string(o.gp.mean)},
        {"prior", to_string(o.gp.prior)},
        {"prior_width", o.gp.prior.width},
        {"warm_start_rows", o.gp.warm_start_rows}}},
      {"sparse",
       {{"inducing_points", o.sparse.inducing_points},
        {"hyperparameter_objective", to_string(o.sparse.hyperparameter_objective)}}},
      {"serial_chain", o.serial_chain},
      {"robot_friction", o.robot_prior.friction},
      {"nn",
       {{"hidden", o.nn.hidden},
        {"epochs", o.nn.epochs},
        {"batch_size", o.nn.batch_size},
        {"learning_rate", o.nn.learning_rate},
        {"validation_fraction", o.nn.validation_fraction},
        {"patience", o.nn.patience},
        {"seed", o.nn.seed}}},
      {"chain",
       {{"starts", o.chain.starts},
        {"rows", o.chain.rows},
        {"length_scale", o.chain.length_scale},
        {"seed", o.chain.seed}}},
  };
}

namespace {

// Reads record[group][key] (group empty: record[key]) into value where the record has it.
// present, where given: whether the record has it.
template <class T>
void read(const nlohmann::json& record, const char* group, const char* key, T& value, bool* present = nullptr) {
  const nlohmann::json* where = &record;
  if (*group) {
    if (!record.contains(group)) return;
    where = &record.at(group);
  }
  if (!where->contains(key)) return;
  try {
    value = where->at(key).get<T>();
    if (present) *present = true;
  } catch (const nlohmann::json::exception&) {
    throw Error(std::string("the options record's ") + (*group ? std::string(group) + "." : std::string()) + key +
                " is not of its type: " + where->at(key).dump());
  }
}

template <class T>
void read_optional(const nlohmann::json& record, const char* group, const char* key, std::optional<T>& value) {
  T read_value{};
  bool present = false;
  read(record, group, key, read_value, &present);
  if (present) value = read_value;
}

template <class Enum>
void read_choice(const nlohmann::json& record, const char* group, const char* key, Enum& value,
                 Enum (*parse)(const std::string&)) {
  std::string name;
  read(record, group, key, name);
  if (!name.empty()) value = parse(name);
}

}  // namespace

EstimatorOptions options_from_record(const nlohmann::json& record) {
  if (!record.is_object()) throw Error("the options record is not a JSON object: " + record.dump());
  EstimatorOptions o;
  read(record, "", "estimator", o.name);
  SearchSettings& s = o.search;
  read_choice(record, "search", "optimizer", s.optimizer.kind, parse_optimizer);
  read(record, "search", "max_iterations", s.optimizer.max_iterations);
  read(record, "search", "lbfgs_memory", s.optimizer.lbfgs_memory);
  read(record, "search", "adam_learning_rate", s.optimizer.adam_learning_rate);
  read(record, "search", "gradient_tolerance_per_row", s.gradient_tolerance_per_row);
  read_optional(record, "search", "restarts", s.restarts);
  read_optional(record, "search", "restart_spread", s.restart_spread);
  read(record, "search", "seed", s.seed);
  read_optional(record, "search", "start_screening_evaluations", s.start_screening_evaluations);
  read(record, "search", "hyperparameter_rows", s.hyperparameter_rows);
  read(record, "search", "min_noise_fraction", s.min_noise_fraction);
  read_choice(record, "gp", "scaling", o.gp.scaling, parse_output_scaling);
  read_choice(record, "gp", "mean", o.gp.mean, parse_mean_kind);
  std::string prior = to_string(o.gp.prior);
  double width = o.gp.prior.width;
  read(record, "gp", "prior", prior);
  read(record, "gp", "prior_width", width);
  o.gp.prior = parse_hyperparameter_prior(prior, width);
  read(record, "gp", "warm_start_rows", o.gp.warm_start_rows);
  read(record, "sparse", "inducing_points", o.sparse.inducing_points);
  read_choice(record, "sparse", "hyperparameter_objective", o.sparse.hyperparameter_objective,
              parse_hyperparameter_objective);
  read(record, "", "serial_chain", o.serial_chain);
  read(record, "", "robot_friction", o.robot_prior.friction);
  read(record, "nn", "hidden", o.nn.hidden);
  read(record, "nn", "epochs", o.nn.epochs);
  read(record, "nn", "batch_size", o.nn.batch_size);
  read(record, "nn", "learning_rate", o.nn.learning_rate);
  // A record without it was written before early stopping: every row trained for all the epochs.
  bool early_stopping_recorded = false;
  read(record, "nn", "validation_fraction", o.nn.validation_fraction, &early_stopping_recorded);
  if (!early_stopping_recorded) o.nn.validation_fraction = 0.0;
  read(record, "nn", "patience", o.nn.patience);
  read(record, "nn", "seed", o.nn.seed);
  read(record, "chain", "starts", o.chain.starts);
  read(record, "chain", "rows", o.chain.rows);
  read(record, "chain", "length_scale", o.chain.length_scale);
  read(record, "chain", "seed", o.chain.seed);
  return o;
}

}  // namespace gipdyn
