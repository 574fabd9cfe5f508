#include "gipdyn/estimators/fisherian.hpp"

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/training_data.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {

namespace {

int regressor_columns(const RobotPrior& prior) { return (prior.friction ? 12 : 10) * prior.robot->num_joints(); }

class FisherianQueryWorkspace final : public QueryWorkspace {
 public:
  FisherianQueryWorkspace(const RobotPrior& prior, const Eigen::VectorXd& weights)
      : QueryWorkspace(prior.robot->num_joints()), prior_(prior), weights_(weights), regressor_(*prior.robot),
        Phi_(prior.robot->num_joints(), regressor_columns(prior)) {}

  void predict(const double* x, double* tau) override {
    const int n = static_cast<int>(Phi_.rows());
    regressor_into(*prior_.robot, x, x + n, x + 2 * n, prior_.friction, regressor_, Phi_);
    Eigen::Map<Eigen::VectorXd>(tau, n).noalias() = Phi_ * weights_;
  }
  bool allocation_free() const override { return true; }

 private:
  const RobotPrior& prior_;
  const Eigen::VectorXd& weights_;
  RegressorWorkspace regressor_;
  Eigen::MatrixXd Phi_;
};

}  // namespace

FisherianEstimator::FisherianEstimator(RobotPrior prior, Eigen::VectorXd weights)
    : prior_(std::move(prior)), weights_(std::move(weights)) {
  if (!prior_.robot) throw Error("the fe estimator needs the nominal robot (EstimatorOptions::robot_prior)");
  joints_ = prior_.robot->joint_types();
  if (weights_.size() != regressor_columns(prior_)) throw Error("fe: one weight per regressor column is needed");
  base_rank_ = static_cast<int>((weights_.array() != 0.0).count());
}

FisherianEstimator FisherianEstimator::fit(const RobotPrior& prior, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y) {
  if (!prior.robot) throw Error("the fe estimator needs the nominal robot (EstimatorOptions::robot_prior)");
  validate_training_data(X, Y, prior.robot->joint_types());
  const BaseParameters base = compute_base_parameters(*prior.robot, prior.friction);
  const Eigen::MatrixXd Phi = base.select(stacked_regressor(*prior.robot, X, prior.friction));
  if (Phi.rows() < Phi.cols())
    throw Error("fe: " + std::to_string(X.rows()) + " samples give fewer equations than the " +
                std::to_string(Phi.cols()) + " base parameters; use more samples");
  // Sample-major stacking, as stacked_regressor orders its rows.
  const Eigen::MatrixXd Yt = Y.transpose();
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(Yt.data(), Yt.size());
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Phi);
  const Eigen::VectorXd wb = qr.solve(y);
  Eigen::VectorXd w = Eigen::VectorXd::Zero(regressor_columns(prior));
  for (size_t k = 0; k < base.independent.size(); ++k) w(base.independent[k]) = wb(static_cast<Eigen::Index>(k));
  return FisherianEstimator(prior, w);
}

FisherianEstimator FisherianEstimator::identified_by(std::string report) && {
  identification_ = report.empty() ? "identified from the log" : std::move(report);
  return std::move(*this);
}

std::unique_ptr<QueryWorkspace> FisherianEstimator::make_query_workspace() const {
  return std::make_unique<FisherianQueryWorkspace>(prior_, weights_);
}

Eigen::MatrixXd FisherianEstimator::predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  const int n = joints_.size();
  if (X.cols() != 3 * n) throw Error("fe: inputs must have " + std::to_string(3 * n) + " columns");
  // Row by row through the single-query path: one regressor workspace for all rows.
  FisherianQueryWorkspace workspace(prior_, weights_);
  Eigen::MatrixXd out(X.rows(), n);
  Eigen::VectorXd x(3 * n), tau(n);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    x = X.row(r).transpose();
    workspace.predict(x.data(), tau.data());
    out.row(r) = tau.transpose();
  }
  return out;
}

ModelContainer FisherianEstimator::to_container() const {
  ModelContainer c;
  c.header["estimator"] = name();
  if (!identification_.empty()) c.header["chain_identification"] = identification_;
  c.header["joints"] = joints_.str();
  c.header["robot"] = robot_to_storable_json(*prior_.robot);
  c.header["robot_friction"] = prior_.friction;
  c.add("weights", weights_);
  return c;
}

std::string FisherianEstimator::name() const {
  return estimator_name(EstimatorFamily::Fisherian, &EstimatorSpec::identifies_chain, !identification_.empty());
}

nlohmann::json FisherianEstimator::summary() const {
  nlohmann::json s = {{"estimator", name()}, {"robot", prior_.robot->name()}, {"friction", prior_.friction},
                       {"base_parameters", base_rank_}};
  if (!identification_.empty()) s["chain_identification"] = identification_;
  return s;
}

FisherianEstimator FisherianEstimator::from_container(const ModelContainer& c, const std::string& what) {
  RobotPrior prior;
  prior.robot = std::make_shared<const RobotModel>(robot_from_storable_json(c.header.at("robot"), what));
  prior.friction = c.header.at("robot_friction").get<bool>();
  const Eigen::MatrixXd& w = c.array("weights", what);
  if (w.cols() != 1 || w.rows() != regressor_columns(prior))
    throw Error(what + " is corrupted (weights shape); re-save the model");
  FisherianEstimator e(prior, w.col(0));
  const std::string stored = c.header.value("estimator", estimator_name(EstimatorFamily::Fisherian));
  if (estimator_spec(stored).identifies_chain)
    return std::move(e).identified_by(c.header.value("chain_identification", std::string()));
  return e;
}

}  // namespace gipdyn
