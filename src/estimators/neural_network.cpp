#include "gipdyn/estimators/neural_network.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/detail/neural_network_plugin.hpp"
#include "gipdyn/io/detail/model_container.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

namespace {

// The libtorch plugin, opened once per process the first time it is needed:
// GIPDYN_TORCH_PLUGIN where set, else the first found of the one beside this
// code (the Python package), the one installed with it, the build tree's and
// the one at the configured prefix.
struct NetworkPlugin {
  GipdynTrainNetwork train = nullptr;
  std::string error;  // why there is none
};

const NetworkPlugin& network_plugin() {
  static const NetworkPlugin plugin = [] {
    NetworkPlugin p;
#ifndef GIPDYN_HAVE_TORCH
    p.error = "this gipdyn was built without libtorch, so it cannot train the nn estimator; install libtorch-dev "
              "(scripts/install-deps.sh) and rebuild";
#else
    std::vector<std::string> candidates;
    if (const char* path = std::getenv("GIPDYN_TORCH_PLUGIN"); path && *path) {
      candidates.push_back(path);
    } else {
      // Beside the program or library this code was linked into, where an
      // installation put both (PREFIX/bin or PREFIX/LIBDIR, and
      // PREFIX/LIBDIR/gipdyn), wherever the prefix was chosen at install time.
      Dl_info self{};
      std::filesystem::path object;
      if (dladdr(reinterpret_cast<void*>(&network_plugin), &self) && self.dli_fname &&
          std::string(self.dli_fname).find('/') != std::string::npos)
        object = self.dli_fname;
      else
        object = "/proc/self/exe";
      std::error_code ec;
      const std::filesystem::path resolved = std::filesystem::canonical(object, ec);
      if (!ec) {
        // The Python package carries it beside its extension module.
        candidates.push_back((resolved.parent_path() / GIPDYN_TORCH_PLUGIN_NAME).string());
        candidates.push_back((resolved.parent_path().parent_path() / GIPDYN_INSTALL_LIBDIR / "gipdyn" /
                              GIPDYN_TORCH_PLUGIN_NAME).string());
      }
      candidates.push_back(GIPDYN_TORCH_PLUGIN_BUILD);
      candidates.push_back(GIPDYN_TORCH_PLUGIN_INSTALLED);
    }
    std::string tried;  // each path tried, and why it was passed over
    auto pass_over = [&](const std::string& path, const std::string& why) {
      tried += (tried.empty() ? "" : ", ") + path + " (" + why + ")";
    };
    for (const std::string& path : candidates) {
      if (!std::filesystem::exists(path)) {
        pass_over(path, "missing");
        continue;
      }
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        const char* why = dlerror();
        pass_over(path, why ? why : "cannot be opened");
        continue;
      }
      auto abi = reinterpret_cast<GipdynNetworkPluginAbi>(dlsym(handle, "gipdyn_network_plugin_abi"));
      auto train = reinterpret_cast<GipdynTrainNetwork>(dlsym(handle, "gipdyn_train_network"));
      if (!abi || !train || abi() != GIPDYN_NETWORK_PLUGIN_ABI) {
        pass_over(path, "from another version of gipdyn");
        continue;  // the handle stays open: unloading libtorch is not safe
      }
      p.train = train;
      return p;
    }
    p.error = "the nn estimator's libtorch plugin could not be loaded: " + tried +
              "; reinstall gipdyn, or set GIPDYN_TORCH_PLUGIN to the path of " GIPDYN_TORCH_PLUGIN_NAME;
#endif
    return p;
  }();
  return plugin;
}

}  // namespace

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

bool neural_network_training_available() { return network_plugin().train != nullptr; }

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
  const NetworkPlugin& plugin = network_plugin();
  if (!plugin.train) throw Error(plugin.error);
  NeuralNetwork net;
  net.joints_ = joints;
  standardisation(X, net.x_mean_, net.x_scale_);
  standardisation(Y, net.y_mean_, net.y_scale_);
  // Row-major copies so that a batch is a contiguous block of rows.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMajor xr = ((X.rowwise() - net.x_mean_).array().rowwise() / net.x_scale_.array()).matrix();
  const RowMajor yr = ((Y.rowwise() - net.y_mean_).array().rowwise() / net.y_scale_.array()).matrix();
  const std::vector<bool> held_out_mask = options.held_out_rows(static_cast<long>(X.rows()));
  std::vector<long long> training_rows, validation_rows;
  for (long long r = 0; r < static_cast<long long>(X.rows()); ++r)
    (held_out_mask[static_cast<size_t>(r)] ? validation_rows : training_rows).push_back(r);
  net.held_out_row_count_ = static_cast<long>(validation_rows.size());
  const std::vector<int> hidden = options.hidden_for(n);

  // libtorch's products run in the OpenBLAS gipdyn links, whose default thread
  // count is the machine's: the trained weights would then differ in the last
  // digits from one machine to another, against the rule that a seed gives
  // the same model everywhere.
  use_single_threaded_blas();
  struct Context {
    NeuralNetwork* net;
    const ProgressCallback* progress;
    std::chrono::steady_clock::time_point t0;
  } context{&net, &progress, std::chrono::steady_clock::now()};
  GipdynNetworkJob job{};
  job.x = xr.data();
  job.y = yr.data();
  job.rows = static_cast<long long>(X.rows());
  job.inputs = 3 * n;
  job.outputs = n;
  job.training_rows = training_rows.data();
  job.training_count = static_cast<long long>(training_rows.size());
  job.validation_rows = validation_rows.data();
  job.validation_count = static_cast<long long>(validation_rows.size());
  job.hidden = hidden.data();
  job.hidden_layers = static_cast<int>(hidden.size());
  job.seed = options.seed;
  job.learning_rate = options.learning_rate;
  job.epochs = options.epochs;
  job.batch_size = options.batch_size;
  job.patience = options.patience;
  job.threads = options.threads;
  job.epoch_done = [](void* c, int epoch, double training_loss) {
    const auto* ctx = static_cast<const Context*>(c);
    if (!*ctx->progress) return;
    ProgressEvent e;
    e.iteration = epoch;
    e.objective = training_loss;
    e.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - ctx->t0).count();
    (*ctx->progress)(e);
  };
  job.layer = [](void* c, const double* W, int rows, int cols, const double* b) {
    NeuralNetwork& net = *static_cast<Context*>(c)->net;
    net.weights_.push_back(Eigen::Map<const RowMajor>(W, rows, cols));
    net.biases_.push_back(Eigen::Map<const Eigen::VectorXd>(b, rows));
  };
  job.context = &context;
  GipdynNetworkOutcome outcome{};
  if (plugin.train(&job, &outcome) != 0) throw Error(std::string("nn: training failed: ") + outcome.error);
  net.epochs_run_ = outcome.epochs_run;
  net.kept_epoch_ = outcome.kept_epoch;
  net.final_loss_ = outcome.training_loss;
  net.validation_loss_ = outcome.validation_loss;
  return net;
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
