#pragma once
// NN, the paper's baseline (docs/method.md): a fully connected network with
// sigmoid hidden layers, trained with Adam on the mean squared error of
// standardised inputs and outputs. Trained with libtorch (Debian's
// libtorch-dev); prediction runs on the stored weights with Eigen, so a
// trained network is usable without libtorch.
#include <Eigen/Dense>
#include <cstdint>
#include <limits>
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
  // The most epochs; fewer where the held-out loss stops falling.
  int epochs = 300;
  int batch_size = 64;
  double learning_rate = 1e-3;
  // Early stopping: this share of the rows is held out: the log cut into
  // kTimeBlocks stretches of consecutive rows, and the nearest whole number of
  // them held out, spread evenly over the log (where the rows are in time
  // order: whole stretches of motion, so that neighbouring samples do not carry
  // a held-out row's torque into training, yet inside the states the log
  // visits, which the log's last stretch alone may leave). The network trains
  // on the other rows and keeps the weights of the epoch with the lowest
  // held-out loss, stopping once `patience` epochs in a row have not lowered it.
  // 0, or fewer than kMinValidationRows rows held out or left to train on:
  // every row trains for all the epochs.
  double validation_fraction = 0.15;
  int patience = 30;
  static constexpr int kTimeBlocks = 20;
  static constexpr int kMinValidationRows = 20;
  std::uint64_t seed = 0;
  int threads = 1;  // libtorch intra-op threads; 1 keeps results bit-reproducible
  void validate() const;  // throws gipdyn::Error naming the bad field
  std::vector<int> hidden_for(int num_joints) const;
  // Whether each of `rows` rows is held out for early stopping (all false: none is).
  std::vector<bool> held_out_rows(long rows) const;
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
  // The mean training loss of the kept epoch (standardised units).
  double final_loss() const { return final_loss_; }
  // Early stopping: the epochs run, the one whose weights were kept, its
  // held-out loss and the number of rows held out (NaN, the last epoch and 0
  // without held-out rows).
  int epochs_run() const { return epochs_run_; }
  int kept_epoch() const { return kept_epoch_; }
  double validation_loss() const { return validation_loss_; }
  long held_out_row_count() const { return held_out_row_count_; }

  void to_container(ModelContainer& c) const;
  static NeuralNetwork from_container(const ModelContainer& c, const std::string& what);

 private:
  JointTypes joints_ = JointTypes::parse("R");
  Eigen::RowVectorXd x_mean_, x_scale_, y_mean_, y_scale_;
  std::vector<Eigen::MatrixXd> weights_;  // layer l: out x in
  std::vector<Eigen::VectorXd> biases_;
  double final_loss_ = 0.0;
  int epochs_run_ = 0, kept_epoch_ = 0;
  long held_out_row_count_ = 0;
  double validation_loss_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace gipdyn
