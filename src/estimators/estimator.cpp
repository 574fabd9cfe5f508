#include "gipdyn/estimators/estimator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/fisherian.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/io/model_file.hpp"

namespace gipdyn {

namespace {

class NeuralNetworkEstimator final : public Estimator {
 public:
  explicit NeuralNetworkEstimator(NeuralNetwork net) : net_(std::move(net)) {}
  std::string name() const override { return "nn"; }
  const JointTypes& joints() const override { return net_.joints(); }
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const override { return net_.predict(X); }
  ModelContainer to_container() const override {
    ModelContainer c;
    c.header["estimator"] = "nn";
    net_.to_container(c);
    return c;
  }
  nlohmann::json summary() const override {
    return {{"estimator", "nn"}, {"weights", net_.num_weights()}, {"final_training_loss", net_.final_loss()}};
  }

 private:
  NeuralNetwork net_;
};

std::string format_seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", s);
  return buf;
}

}  // namespace

ModelContainer GpEstimator::to_container() const { return model_to_container(model_); }

nlohmann::json GpEstimator::summary() const {
  nlohmann::json joints = nlohmann::json::array();
  for (int j = 0; j < model_.num_joints(); ++j) {
    nlohmann::json hp = nlohmann::json::object();
    for (const auto& [name, value] : model_.hyperparameters(j)) hp[name] = value;
    joints.push_back({{"joint", j + 1}, {"nll", model_.joint_gp(j).nll()}, {"hyperparameters", hp}});
  }
  return {{"estimator", "gp"}, {"kernel", model_.kernel_name()}, {"joints", joints}};
}

const std::vector<std::string>& estimator_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = kernel_names();
    n.push_back("fe");
    n.push_back("nn");
    return n;
  }();
  return names;
}

bool is_gp_estimator(const std::string& name) {
  const auto& k = kernel_names();
  return std::find(k.begin(), k.end(), name) != k.end();
}

bool estimator_needs_robot(const std::string& name) { return name == "fe" || kernel_needs_robot(name); }

void require_known_estimator(const std::string& name) { require_one_of(name, estimator_names(), "estimator"); }

void EstimatorOptions::validate() const {
  require_known_estimator(name);
  if (estimator_needs_robot(name) && !robot_prior.robot)
    throw Error("estimator '" + name + "' is model-based and needs the nominal robot; pass --robot");
  if (name == "nn") nn.validate();
  if (is_gp_estimator(name)) train_options().validate();
}

TrainOptions EstimatorOptions::train_options() const {
  TrainOptions o = gp;
  o.kernel = name;
  o.robot_prior = robot_prior;
  return o;
}

FitResult fit_estimator(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                        const JointTypes& joints, const FitCallback& progress) {
  options.validate();
  validate_training_data(X, Y, joints);
  if (estimator_needs_robot(options.name)) require_matching_robot(options.robot_prior, joints);
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  auto report = [&](const std::string& msg, bool finished) {
    if (progress) progress({options.name, msg, finished});
  };
  FitResult result;
  if (is_gp_estimator(options.name)) {
    const TrainOptions o = options.train_options();
    TrainingCallback cb;
    if (progress)
      cb = [&](const TrainingProgress& p) {
        if (!p.finished && p.iteration != 1 && p.iteration % 10 != 0) return;
        char buf[200];
        if (p.finished)
          std::snprintf(buf, sizeof buf, "joint %d done: NLL %.6g after %d evaluations (%.1f s)%s%s", p.joint + 1,
                        p.nll, p.iteration, p.seconds, p.message.empty() ? "" : ": ", p.message.c_str());
        else
          std::snprintf(buf, sizeof buf, "joint %d restart %d iteration %d: NLL %.6g |grad| %.3g (%.1f s)",
                        p.joint + 1, p.restart, p.iteration, p.nll, p.grad_norm, p.seconds);
        report(buf, false);
      };
    TrainResult r = train_model(X, Y, joints, o, cb);
    result.ok = r.ok;
    result.message = r.message;
    result.joint_reports = r.joints;
    if (r.ok) result.estimator = std::make_unique<GpEstimator>(std::move(r.model));
  } else if (options.name == "fe") {
    result.estimator = std::make_unique<FisherianEstimator>(FisherianEstimator::fit(options.robot_prior, X, Y));
    result.ok = true;
  } else {  // nn
    const int every = std::max(1, options.nn.epochs / 20);
    NeuralNetwork net = NeuralNetwork::train(X, Y, joints, options.nn, [&](int epoch, double loss) {
      if (epoch % every == 0 || epoch == options.nn.epochs)
        report("epoch " + std::to_string(epoch) + "/" + std::to_string(options.nn.epochs) +
                   ": training loss " + std::to_string(loss) + " (" + format_seconds(elapsed()) + ")",
               false);
    });
    if (!std::isfinite(net.final_loss())) {
      result.message = "nn: the training loss diverged (NaN); lower --nn-lr";
    } else {
      result.estimator = std::make_unique<NeuralNetworkEstimator>(std::move(net));
      result.ok = true;
    }
  }
  result.seconds = elapsed();
  report(result.ok ? "fitted in " + format_seconds(result.seconds) : "failed: " + result.message, true);
  return result;
}

std::unique_ptr<Estimator> estimator_from_container(const ModelContainer& c, const std::string& what) {
  std::string kind;
  try {
    kind = c.header.value("estimator", "gp");
    if (kind == "gp") return std::make_unique<GpEstimator>(model_from_container(c, what));
    if (kind == "fe") return std::make_unique<FisherianEstimator>(FisherianEstimator::from_container(c, what));
    if (kind == "nn") return std::make_unique<NeuralNetworkEstimator>(NeuralNetwork::from_container(c, what));
  } catch (const nlohmann::json::exception& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
  throw Error(what + " holds an unknown estimator '" + kind + "'; upgrade gipdyn");
}

void save_estimator(const Estimator& estimator, const std::string& path) {
  ModelContainer c = estimator.to_container();
  c.header["format"] = "gipdyn-model";
  c.header["format_version"] = kModelFormatVersion;
  write_container(c, path);
}

std::unique_ptr<Estimator> load_estimator(const std::string& path) {
  const std::string what = "model file '" + path + "'";
  return estimator_from_container(unpack_container(read_model_bytes(path), what), what);
}

}  // namespace gipdyn
