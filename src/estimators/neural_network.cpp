#include "gipdyn/estimators/neural_network.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/training_data.hpp"

#ifdef GIPDYN_HAVE_TORCH
#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>
#include "gipdyn/io/detail/model_container.hpp"
#endif

namespace gipdyn {

#ifdef GIPDYN_HAVE_TORCH
namespace {

// Each fit draws its initial weights from a generator of its own. Seeding
// libtorch's global generator instead made fits running on other threads at
// the same time draw from one stream, so their weights depended on which
// thread drew first. The draws are libtorch's own default initialisation
// (Linear::reset_parameters: kaiming_uniform_ with a = sqrt(5) for the weight,
// U(-1/sqrt(fan_in), 1/sqrt(fan_in)) for the bias), in its order and at its
// single precision, so that a seed gives the network it always gave.
void draw_initial_weights(torch::nn::Sequential& model, std::uint64_t seed) {
  at::Generator generator = at::detail::createCPUGenerator(seed);
  torch::NoGradGuard no_grad;
  const double a = std::sqrt(5.0);
  const double gain = std::sqrt(2.0 / (1 + std::pow(a, 2)));
  for (const auto& module : model->children()) {
    auto* linear = module->as<torch::nn::Linear>();
    if (!linear) continue;
    const int64_t fan_in = linear->weight.size(1);
    const double weight_bound = std::sqrt(3.0) * (gain / std::sqrt(fan_in));
    linear->weight.uniform_(-weight_bound, weight_bound, generator);
    const double bias_bound = 1 / std::sqrt(fan_in);
    linear->bias.uniform_(-bias_bound, bias_bound, generator);
  }
}

}  // namespace
#endif

void NeuralNetworkOptions::validate() const {
  for (int h : hidden)
    if (h < 1) throw Error("NeuralNetworkOptions::hidden: every layer needs at least one unit");
  if (epochs < 1) throw Error("NeuralNetworkOptions::epochs must be >= 1");
  if (batch_size < 1) throw Error("NeuralNetworkOptions::batch_size must be >= 1");
  if (!(learning_rate > 0.0)) throw Error("NeuralNetworkOptions::learning_rate must be > 0");
  if (threads < 1) throw Error("NeuralNetworkOptions::threads must be >= 1");
  if (!(validation_fraction >= 0.0 && validation_fraction < 1.0))
    throw Error("NeuralNetworkOptions::validation_fraction must be in [0, 1) (0: no early stopping)");
  if (patience < 1) throw Error("NeuralNetworkOptions::patience must be >= 1");
}

std::vector<bool> NeuralNetworkOptions::held_out_rows(long rows) const {
  std::vector<bool> held_out(static_cast<size_t>(rows), false);
  const int blocks = static_cast<int>(std::lround(validation_fraction * kTimeBlocks));
  if (blocks < 1) return held_out;
  long count = 0;
  for (int b = 0; b < blocks; ++b) {
    // Block k of kTimeBlocks, spread evenly: the middle of each of `blocks` equal parts of the log.
    const long k = (2L * b + 1) * kTimeBlocks / (2L * blocks);
    for (long r = k * rows / kTimeBlocks; r < (k + 1) * rows / kTimeBlocks; ++r, ++count) held_out[static_cast<size_t>(r)] = true;
  }
  if (count < kMinValidationRows || rows - count < kMinValidationRows) held_out.assign(held_out.size(), false);
  return held_out;
}

std::vector<int> NeuralNetworkOptions::hidden_for(int num_joints) const {
  if (!hidden.empty()) return hidden;
  const int width = num_joints >= 6 ? 600 : 400;
  return {width, width};
}

bool neural_network_training_available() {
#ifdef GIPDYN_HAVE_TORCH
  return true;
#else
  return false;
#endif
}

namespace {

// Column means and population standard deviations (1 where a column is constant).
void standardisation(const Eigen::MatrixXd& A, Eigen::RowVectorXd& mean, Eigen::RowVectorXd& scale) {
  mean = A.colwise().mean();
  scale = ((A.rowwise() - mean).array().square().colwise().mean()).sqrt().matrix();
  for (Eigen::Index c = 0; c < scale.size(); ++c)
    if (!(scale(c) > 1e-12)) scale(c) = 1.0;
}

}  // namespace

NeuralNetwork NeuralNetwork::train(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                                   const NeuralNetworkOptions& options, const ProgressCallback& progress) {
  options.validate();
  validate_training_data(X, Y, joints);
  const int n = joints.size();
  {
    // Weights, gradients and Adam's two moments, plus one batch of activations per layer.
    double weights = 0.0, activations = 0.0;
    int width = 3 * n;
    for (int h : options.hidden_for(n)) {
      weights += (width + 1.0) * h;
      activations += static_cast<double>(options.batch_size) * h;
      width = h;
    }
    weights += (width + 1.0) * n;
    require_memory(8.0 * (4.0 * weights + 3.0 * activations), "a network of this shape",
                   "use narrower layers (NeuralNetworkOptions::hidden) or smaller batches");
  }
#ifndef GIPDYN_HAVE_TORCH
  (void)progress;
  throw Error("this gipdyn was built without libtorch, so it cannot train the nn estimator; "
              "install libtorch-dev (scripts/install-deps.sh) and rebuild");
#else
  NeuralNetwork net;
  net.joints_ = joints;
  standardisation(X, net.x_mean_, net.x_scale_);
  standardisation(Y, net.y_mean_, net.y_scale_);
  const Eigen::MatrixXd Xs = ((X.rowwise() - net.x_mean_).array().rowwise() / net.x_scale_.array()).matrix();
  const Eigen::MatrixXd Ys = ((Y.rowwise() - net.y_mean_).array().rowwise() / net.y_scale_.array()).matrix();

  const auto t0 = std::chrono::steady_clock::now();
  torch::set_num_threads(options.threads);
  // libtorch's products run in the OpenBLAS gipdyn links, whose default thread
  // count is the machine's: the trained weights would then differ in the last
  // digits from one machine to another, against the rule that a seed gives
  // the same model everywhere.
  use_single_threaded_blas();
  const std::vector<int> hidden = options.hidden_for(n);
  torch::nn::Sequential model;
  int width = 3 * n;
  for (int h : hidden) {
    model->push_back(torch::nn::Linear(width, h));
    model->push_back(torch::nn::Sigmoid());
    width = h;
  }
  model->push_back(torch::nn::Linear(width, n));
  draw_initial_weights(model, options.seed);
  model->to(torch::kDouble);

  // Row-major copies so that a batch is a contiguous block of rows.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMajor xr = Xs, yr = Ys;
  const auto rows = static_cast<int64_t>(X.rows());
  const torch::Tensor x_all = torch::from_blob(const_cast<double*>(xr.data()), {rows, 3 * n}, torch::kDouble).clone();
  const torch::Tensor y_all = torch::from_blob(const_cast<double*>(yr.data()), {rows, n}, torch::kDouble).clone();
  const std::vector<bool> held_out_mask = options.held_out_rows(rows);
  std::vector<int64_t> training_rows, validation_rows;
  for (int64_t r = 0; r < rows; ++r) (held_out_mask[static_cast<size_t>(r)] ? validation_rows : training_rows).push_back(r);
  const auto held_out = static_cast<int64_t>(validation_rows.size());
  const int64_t N = rows - held_out;
  net.held_out_row_count_ = static_cast<long>(held_out);
  auto select = [](const torch::Tensor& t, std::vector<int64_t>& indices) {
    return t.index_select(0, torch::from_blob(indices.data(), {static_cast<int64_t>(indices.size())}, torch::kLong));
  };
  const torch::Tensor xt = select(x_all, training_rows), yt = select(y_all, training_rows);
  const torch::Tensor xv = held_out > 0 ? select(x_all, validation_rows) : torch::Tensor();
  const torch::Tensor yv = held_out > 0 ? select(y_all, validation_rows) : torch::Tensor();

  torch::optim::Adam adam(model->parameters(), torch::optim::AdamOptions(options.learning_rate));
  std::mt19937_64 rng(options.seed);
  std::vector<int64_t> order(static_cast<size_t>(N));
  std::iota(order.begin(), order.end(), 0);
  std::vector<torch::Tensor> kept;  // the parameters of the epoch with the lowest held-out loss
  double best = std::numeric_limits<double>::infinity();
  for (int epoch = 1; epoch <= options.epochs; ++epoch) {
    std::shuffle(order.begin(), order.end(), rng);
    const torch::Tensor perm = torch::from_blob(order.data(), {N}, torch::kLong).clone();
    double total = 0.0;
    for (int64_t start = 0; start < N; start += options.batch_size) {
      const int64_t stop = std::min<int64_t>(N, start + options.batch_size);
      const torch::Tensor idx = perm.slice(0, start, stop);
      adam.zero_grad();
      const torch::Tensor loss = torch::mse_loss(model->forward(xt.index_select(0, idx)), yt.index_select(0, idx));
      loss.backward();
      adam.step();
      total += loss.item<double>() * static_cast<double>(stop - start);
    }
    const double training_loss = total / static_cast<double>(N);
    net.epochs_run_ = epoch;
    bool stop = false;
    if (held_out == 0) {
      net.final_loss_ = training_loss;
      net.kept_epoch_ = epoch;
    } else {
      torch::NoGradGuard no_grad;
      const double validation = torch::mse_loss(model->forward(xv), yv).item<double>();
      if (validation < best) {  // NaN never improves: a diverged run keeps its last good epoch
        best = validation;
        net.final_loss_ = training_loss;
        net.validation_loss_ = validation;
        net.kept_epoch_ = epoch;
        kept.clear();
        for (const auto& p : model->parameters()) kept.push_back(p.detach().clone());
      }
      stop = epoch - net.kept_epoch_ >= options.patience;
    }
    if (progress) {
      ProgressEvent e;
      e.iteration = epoch;
      e.objective = training_loss;
      e.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      progress(e);
    }
    if (stop) break;
  }
  if (held_out > 0) {
    if (kept.empty()) {  // no epoch gave a finite held-out loss
      net.final_loss_ = std::numeric_limits<double>::quiet_NaN();
    } else {
      torch::NoGradGuard no_grad;
      const auto parameters = model->parameters();
      for (size_t k = 0; k < parameters.size(); ++k) parameters[k].copy_(kept[k]);
    }
  }

  for (const auto& module : model->children()) {
    if (auto* linear = module->as<torch::nn::Linear>()) {
      const torch::Tensor w = linear->weight.detach().contiguous();
      const torch::Tensor b = linear->bias.detach().contiguous();
      net.weights_.push_back(Eigen::Map<const RowMajor>(w.data_ptr<double>(), w.size(0), w.size(1)));
      net.biases_.push_back(Eigen::Map<const Eigen::VectorXd>(b.data_ptr<double>(), b.size(0)));
    }
  }
  return net;
#endif
}

Eigen::MatrixXd NeuralNetwork::predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  const int n = joints_.size();
  if (X.cols() != 3 * n) throw Error("NN: inputs must have " + std::to_string(3 * n) + " columns");
  Eigen::MatrixXd h = ((X.rowwise() - x_mean_).array().rowwise() / x_scale_.array()).matrix();
  for (size_t l = 0; l < weights_.size(); ++l) {
    Eigen::MatrixXd next = (h * weights_[l].transpose()).rowwise() + biases_[l].transpose();
    if (l + 1 < weights_.size()) next = (1.0 / (1.0 + (-next.array()).exp())).matrix();
    h = std::move(next);
  }
  return ((h.array().rowwise() * y_scale_.array()).rowwise() + y_mean_.array()).matrix();
}

int NeuralNetwork::widest_layer() const {
  Eigen::Index w = x_mean_.size();
  for (const auto& W : weights_) w = std::max(w, W.rows());
  return static_cast<int>(w);
}

void NeuralNetwork::predict_one(const double* x, double* tau, Eigen::VectorXd& a, Eigen::VectorXd& b) const {
  const Eigen::Index d = x_mean_.size();
  a.head(d) = ((Eigen::Map<const Eigen::RowVectorXd>(x, d) - x_mean_).array() / x_scale_.array()).transpose();
  Eigen::VectorXd* in = &a;
  Eigen::VectorXd* out = &b;
  for (size_t l = 0; l < weights_.size(); ++l) {
    const Eigen::Index rows = weights_[l].rows(), cols = weights_[l].cols();
    out->head(rows).noalias() = weights_[l] * in->head(cols);
    out->head(rows) += biases_[l];
    if (l + 1 < weights_.size()) out->head(rows) = (1.0 / (1.0 + (-out->head(rows).array()).exp())).matrix();
    std::swap(in, out);
  }
  const Eigen::Index n = y_mean_.size();
  Eigen::Map<Eigen::RowVectorXd>(tau, n) =
      (in->head(n).transpose().array() * y_scale_.array() + y_mean_.array()).matrix();
}

int NeuralNetwork::num_weights() const {
  int k = 0;
  for (size_t l = 0; l < weights_.size(); ++l) k += static_cast<int>(weights_[l].size() + biases_[l].size());
  return k;
}

void NeuralNetwork::to_container(ModelContainer& c) const {
  c.header["joints"] = joints_.str();
  c.header["layers"] = static_cast<int>(weights_.size());
  c.header["final_training_loss"] = final_loss_;
  c.header["epochs_run"] = epochs_run_;
  c.header["kept_epoch"] = kept_epoch_;
  if (std::isfinite(validation_loss_)) c.header["validation_loss"] = validation_loss_;
  if (held_out_row_count_ > 0) c.header["held_out_rows"] = held_out_row_count_;
  c.add("x_mean", x_mean_);
  c.add("x_scale", x_scale_);
  c.add("y_mean", y_mean_);
  c.add("y_scale", y_scale_);
  for (size_t l = 0; l < weights_.size(); ++l) {
    c.add("W" + std::to_string(l + 1), weights_[l]);
    c.add("b" + std::to_string(l + 1), biases_[l]);
  }
}

NeuralNetwork NeuralNetwork::from_container(const ModelContainer& c, const std::string& what) {
  NeuralNetwork net;
  net.joints_ = JointTypes::parse(c.header.at("joints").get<std::string>());
  const int n = net.joints_.size();
  net.final_loss_ = c.header.value("final_training_loss", 0.0);
  net.epochs_run_ = c.header.value("epochs_run", 0);  // 0: a file that did not record it
  net.kept_epoch_ = c.header.value("kept_epoch", net.epochs_run_);
  net.validation_loss_ = c.header.value("validation_loss", std::numeric_limits<double>::quiet_NaN());
  net.held_out_row_count_ = c.header.value("held_out_rows", 0L);
  auto row = [&](const std::string& name, int size) -> Eigen::RowVectorXd {
    const Eigen::MatrixXd& a = c.array(name, what);
    if (a.rows() != 1 || a.cols() != size) throw Error(what + " is corrupted (shape of " + name + "); re-save the model");
    return a.row(0);
  };
  net.x_mean_ = row("x_mean", 3 * n);
  net.x_scale_ = row("x_scale", 3 * n);
  net.y_mean_ = row("y_mean", n);
  net.y_scale_ = row("y_scale", n);
  const int layers = c.header.at("layers").get<int>();
  Eigen::Index width = 3 * n;
  for (int l = 1; l <= layers; ++l) {
    const Eigen::MatrixXd& W = c.array("W" + std::to_string(l), what);
    const Eigen::MatrixXd& b = c.array("b" + std::to_string(l), what);
    if (W.cols() != width || b.cols() != 1 || b.rows() != W.rows())
      throw Error(what + " is corrupted (layer " + std::to_string(l) + " shape); re-save the model");
    net.weights_.push_back(W);
    net.biases_.push_back(b.col(0));
    width = net.weights_.back().rows();
  }
  if (width != n) throw Error(what + " is corrupted (output layer width); re-save the model");
  return net;
}

}  // namespace gipdyn
