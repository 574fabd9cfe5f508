#include "gipdyn/model/model_file.hpp"

#include <cmath>
#include <limits>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/json_numbers.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

std::vector<double> to_vector(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }

// A report's number is NaN where there is none to report (the gradient of a fit whose every
// evaluation failed, a failed restart's NLL): number_or_null writes it as null.
nlohmann::json training_to_json(const JointReport& r) {
  nlohmann::json restart_nlls = nlohmann::json::array();
  for (double v : r.restart_nlls) restart_nlls.push_back(number_or_null(v));
  nlohmann::json t = {{"status", to_string(r.status)},
                      {"evaluations", r.evaluations},
                      {"nll", number_or_null(r.nll)},
                      {"warm_start_evaluations", r.warm_start_evaluations},
                      {"screening_evaluations", r.screening_evaluations},
                      {"hyperparameter_rows", r.hyperparameter_rows},
                      {"grad_norm", number_or_null(r.grad_norm)},
                      {"noise_variance", number_or_null(r.noise_variance)},
                      {"jitter", number_or_null(r.jitter)},
                      {"seconds", r.seconds},
                      {"restart_nlls", restart_nlls},
                      {"message", r.message}};
  if (std::isfinite(r.noise_share)) t["noise_share"] = r.noise_share;
  return t;
}

JointReport training_from_json(const nlohmann::json& t, int joint) {
  JointReport r;
  r.joint = joint;
  r.status = parse_optimizer_status(t.at("status").get<std::string>());
  r.evaluations = t.at("evaluations").get<int>();
  r.warm_start_evaluations = t.value("warm_start_evaluations", 0);  // absent before warm starts existed
  r.screening_evaluations = t.value("screening_evaluations", 0);    // absent before screening existed
  r.hyperparameter_rows = t.value("hyperparameter_rows", 0L);       // absent before such subsamples existed
  r.nll = number_or_nan(t.at("nll"));
  r.grad_norm = number_or_nan(t.at("grad_norm"));
  r.noise_variance = number_or_nan(t.at("noise_variance"));
  if (t.contains("noise_share")) r.noise_share = t.at("noise_share").get<double>();  // absent before it existed
  r.jitter = number_or_nan(t.at("jitter"));
  r.seconds = t.at("seconds").get<double>();
  for (const auto& v : t.at("restart_nlls")) r.restart_nlls.push_back(number_or_nan(v));
  r.message = t.at("message").get<std::string>();
  return r;
}

}  // namespace

ModelContainer model_to_container(const InverseDynamicsModel& model) {
  const int n = model.num_joints();
  ModelContainer c;
  nlohmann::json& h = c.header;
  h["estimator"] = "gp";
  h["joints"] = model.joints().str();
  h["kernel"] = model.kernel_name();
  h["num_training_samples"] = model.num_training_samples();
  if (model.is_sparse()) {  // X holds the inducing rows; each joint adds the factor of its A
    h["approximation"] = "vfe";
    h["num_data_rows"] = model.num_data_rows();
  }
  h["output_scaling"] = to_string(model.output_scaling());
  if (model.robot_prior().robot) {
    h["robot"] = robot_to_storable_json(*model.robot_prior().robot);
    h["robot_friction"] = model.robot_prior().friction;
  }
  nlohmann::json joints = nlohmann::json::array();
  c.add("X", model.training_inputs());
  for (int j = 0; j < n; ++j) {
    const GpRegressor& gp = model.joint_gp(j);
    joints.push_back({{"joint", j + 1},
                      {"output_offset", model.output_offset()(j)},
                      {"output_scale", model.output_scale()(j)},
                      {"param_names", gp.kernel().param_names()},
                      {"log_params", to_vector(gp.kernel().log_params())},
                      {"log_noise_variance", gp.log_noise_variance()},
                      {"jitter", gp.jitter()},
                      {"nll", gp.nll()},
                      {"mean", {{"kind", to_string(model.joint_mean(j).kind())},
                                {"coefficients", to_vector(model.joint_mean(j).params())}}}});
    if (!model.training_report().empty())
      joints.back()["training"] = training_to_json(model.training_report()[static_cast<size_t>(j)]);
    c.add("alpha" + std::to_string(j + 1), gp.alpha());
    if (gp.is_sparse()) c.add("posterior_factor" + std::to_string(j + 1), gp.posterior_factor());
  }
  h["joint_models"] = joints;
  return c;
}

InverseDynamicsModel model_from_container(const ModelContainer& c, const std::string& what) {
  using nlohmann::json;
  const json& h = c.header;
  try {
    const std::string estimator = h.value("estimator", "gp");  // format 1 files hold GP models only
    if (estimator != "gp")
      throw Error(what + " holds a '" + estimator + "' estimator, not a GP model; load it with load_estimator");
    const JointTypes joints = JointTypes::parse(h.at("joints").get<std::string>());
    const int n = joints.size();
    const Eigen::Index N = h.at("num_training_samples").get<Eigen::Index>();
    const Eigen::MatrixXd& X = c.array("X", what);
    if (X.rows() != N || X.cols() != 3 * n) throw Error(what + " is corrupted (training input shape); re-save the model");
    const std::string kernel_name = h.at("kernel").get<std::string>();
    const std::string approximation = h.value("approximation", "exact");
    if (approximation != "exact" && approximation != "vfe")
      throw Error(what + " uses the unknown GP approximation '" + approximation + "'; re-save the model");
    const bool sparse = approximation == "vfe";
    RobotPrior prior;
    if (h.contains("robot")) {
      prior.robot = std::make_shared<const RobotModel>(robot_from_storable_json(h.at("robot"), what));
      prior.friction = h.at("robot_friction").get<bool>();
    }
    const FeatureMap features(joints);
    std::vector<GpRegressor> gps;
    std::vector<MeanFunction> means;
    std::vector<JointReport> training;  // files written before it was recorded have none
    Eigen::VectorXd offset(n), scale(n);
    const json& jm = h.at("joint_models");
    if (static_cast<int>(jm.size()) != n) throw Error(what + " is corrupted (wrong number of joint models)");
    for (int j = 0; j < n; ++j) {
      const json& e = jm.at(static_cast<size_t>(j));
      std::unique_ptr<Kernel> k = make_kernel(kernel_name, features, j, prior);
      const auto p = e.at("log_params").get<std::vector<double>>();
      if (static_cast<int>(p.size()) != k->num_params()) throw Error(what + " is corrupted (parameter count)");
      k->set_log_params(Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<Eigen::Index>(p.size())));
      GpRegressor gp(std::move(k), e.at("log_noise_variance").get<double>());
      const Eigen::MatrixXd& alpha = c.array("alpha" + std::to_string(j + 1), what);
      if (alpha.rows() != N || alpha.cols() != 1) throw Error(what + " is corrupted (alpha shape); re-save the model");
      if (sparse) {
        const Eigen::MatrixXd& La = c.array("posterior_factor" + std::to_string(j + 1), what);
        if (La.rows() != N || La.cols() != N) throw Error(what + " is corrupted (posterior factor shape); re-save the model");
        gp.set_sparse_state(alpha.col(0), e.at("jitter").get<double>(), e.at("nll").get<double>(), Eigen::MatrixXd(), La);
      } else {
        gp.set_state(alpha.col(0), e.at("jitter").get<double>(), e.at("nll").get<double>());
      }
      gps.push_back(std::move(gp));
      MeanFunction mean;  // files written before mean functions existed hold zero means
      if (e.contains("mean")) {
        mean = MeanFunction(parse_mean_kind(e.at("mean").at("kind").get<std::string>()), 3 * n);
        const auto b = e.at("mean").at("coefficients").get<std::vector<double>>();
        if (static_cast<int>(b.size()) != mean.num_params())
          throw Error(what + " is corrupted (mean coefficient count); re-save the model");
        mean.set_params(Eigen::Map<const Eigen::VectorXd>(b.data(), static_cast<Eigen::Index>(b.size())));
      }
      means.push_back(mean);
      if (e.contains("training")) training.push_back(training_from_json(e.at("training"), j));
      offset(j) = e.at("output_offset").get<double>();
      scale(j) = e.at("output_scale").get<double>();
    }
    return InverseDynamicsModel(joints, kernel_name, X, std::move(gps),
                                parse_output_scaling(h.at("output_scaling").get<std::string>()), offset, scale,
                                prior, std::move(means),
                                static_cast<int>(training.size()) == n ? std::move(training) : std::vector<JointReport>{},
                                sparse ? h.at("num_data_rows").get<Eigen::Index>() : N);
  } catch (const json::exception& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
}

std::string serialize_model(const InverseDynamicsModel& model) { return pack_container(model_to_container(model)); }

InverseDynamicsModel deserialize_model(const std::string& bytes, const std::string& what) {
  return model_from_container(unpack_container(bytes, what), what);
}

void save_model(const InverseDynamicsModel& model, const std::string& path) {
  write_container(model_to_container(model), path);
}

InverseDynamicsModel load_model(const std::string& path) {
  return deserialize_model(read_model_bytes(path), "model file '" + path + "'");
}

}  // namespace gipdyn
