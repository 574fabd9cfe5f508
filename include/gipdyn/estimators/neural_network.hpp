#pragma once
// NN, the paper's baseline (docs/method.md): a fully connected network with
// sigmoid hidden layers, trained with Adam on the mean squared error of
// standardised inputs and outputs. Trained with libtorch (Debian's
// libtorch-dev); prediction runs on the stored weights with Eigen, so a
// trained network is usable without libtorch.
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

// The model file container (io/detail/model_container.hpp, docs/model-format.md).
struct ModelContainer;

struct NeuralNetworkOptions {
  // Hidden layer widths; empty: two layers of 400 units, 600 for robots with 6 or more joints (the paper's).
  std::vector<int> hidden;
  int epochs = 300;
  int batch_size = 64;
  double learning_rate = 1e-3;
  std::uint64_t seed = 0;
  int threads = 1;  // libtorch intra-op threads; 1 keeps results bit-reproducible
  void validate() const;  // throws gipdyn::Error naming the bad field
  std::vector<int> hidden_for(int num_joints) const;
};

// Whether this build can train networks (libtorch found at configure time).
bool neural_network_training_available();

class NeuralNetwork {
 public:
  NeuralNetwork() = default;
  // Trains on X (N x 3n) -> Y (N x n); validates the options and the data first.
  // progress gets one event per epoch (iteration = epoch, objective = mean
  // training loss). Throws gipdyn::Error when libtorch is missing.
  static NeuralNetwork train(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                             const NeuralNetworkOptions& options, const ProgressCallback& progress = {});

  const JointTypes& joints() const { return joints_; }
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const;
  // One row x (3n) into tau (n), through two buffers of at least
  // widest_layer() entries each: no allocation.
  void predict_one(const double* x, double* tau, Eigen::VectorXd& a, Eigen::VectorXd& b) const;
  int widest_layer() const;
  int num_weights() const;
  double final_loss() const { return final_loss_; }

  void to_container(ModelContainer& c) const;
  static NeuralNetwork from_container(const ModelContainer& c, const std::string& what);

 private:
  JointTypes joints_ = JointTypes::parse("R");
  Eigen::RowVectorXd x_mean_, x_scale_, y_mean_, y_scale_;
  std::vector<Eigen::MatrixXd> weights_;  // layer l: out x in
  std::vector<Eigen::VectorXd> biases_;
  double final_loss_ = 0.0;
};

}  // namespace gipdyn
