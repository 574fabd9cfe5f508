#pragma once
// Every way gipdyn learns inverse dynamics, behind one interface: fit on a
// dataset, predict torques, save to a model file. Selected by name:
//   GP kernels  gip, gip-friction, rbf, gip+rbf, gip-friction+rbf, pp, sp
//   fe          least squares on the rigid-body regressor (base parameters)
//   nn          fully connected network (METHOD.md §5)
// fe, pp and sp use the nominal robot of EstimatorOptions::robot_prior.
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/estimators/neural_network.hpp"
#include "gipdyn/io/model_container.hpp"
#include "gipdyn/joint_types.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/training.hpp"

namespace gipdyn {

class Estimator {
 public:
  virtual ~Estimator() = default;
  virtual std::string name() const = 0;
  virtual const JointTypes& joints() const = 0;
  // Torques (M x n) for every row of X (M x 3n: q, qd, qdd).
  virtual Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const = 0;
  // The estimator as a model file's contents (header + arrays).
  virtual ModelContainer to_container() const = 0;
  // What was learned, for reports: hyperparameters, noise, weights count...
  virtual nlohmann::json summary() const = 0;
};

// Names accepted by fit_estimator: the GP kernels, then fe and nn.
const std::vector<std::string>& estimator_names();
bool is_gp_estimator(const std::string& name);
bool estimator_needs_robot(const std::string& name);
// Throws gipdyn::Error listing the valid names.
void require_known_estimator(const std::string& name);

struct EstimatorOptions {
  std::string name = "gip";
  TrainOptions gp;          // GP estimators (gp.kernel is set from name)
  NeuralNetworkOptions nn;  // nn
  RobotPrior robot_prior;   // fe, pp, sp
  // Throws gipdyn::Error naming the bad option.
  void validate() const;
  // gp with the kernel and robot prior of this estimator.
  TrainOptions train_options() const;
};

struct FitProgress {
  std::string estimator;
  std::string message;  // one line: which joint/epoch, objective, elapsed
  bool finished = false;
};
using FitCallback = std::function<void(const FitProgress&)>;

struct FitResult {
  bool ok = false;
  std::string message;  // on failure: what went wrong
  std::unique_ptr<Estimator> estimator;
  double seconds = 0.0;
  std::vector<JointReport> joint_reports;  // GP estimators: one per joint
};

// Fits the named estimator; a numerical failure is reported in FitResult, bad
// input or options throw gipdyn::Error. The callback may be called from worker threads.
FitResult fit_estimator(const EstimatorOptions& options, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                        const JointTypes& joints, const FitCallback& progress = {});

// Written atomically; read back whatever the estimator.
void save_estimator(const Estimator& estimator, const std::string& path);
std::unique_ptr<Estimator> load_estimator(const std::string& path);
std::unique_ptr<Estimator> estimator_from_container(const ModelContainer& container, const std::string& what);

}  // namespace gipdyn
