// The libtorch plugin (libgipdyn_torch.so): trains the nn estimator's network
// from standardised data and hands its layers back
// (gipdyn/estimators/detail/neural_network_plugin.hpp says why it is a plugin).
#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "gipdyn/estimators/detail/neural_network_plugin.hpp"

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

void train(const GipdynNetworkJob& job, GipdynNetworkOutcome& outcome) {
  torch::set_num_threads(job.threads);
  torch::nn::Sequential model;
  int width = job.inputs;
  for (int l = 0; l < job.hidden_layers; ++l) {
    model->push_back(torch::nn::Linear(width, job.hidden[l]));
    model->push_back(torch::nn::Sigmoid());
    width = job.hidden[l];
  }
  model->push_back(torch::nn::Linear(width, job.outputs));
  draw_initial_weights(model, job.seed);
  model->to(torch::kDouble);

  const torch::Tensor x_all =
      torch::from_blob(const_cast<double*>(job.x), {job.rows, job.inputs}, torch::kDouble).clone();
  const torch::Tensor y_all =
      torch::from_blob(const_cast<double*>(job.y), {job.rows, job.outputs}, torch::kDouble).clone();
  auto select = [](const torch::Tensor& t, const long long* rows, long long count) {
    std::vector<int64_t> indices(rows, rows + count);
    return t.index_select(0, torch::from_blob(indices.data(), {count}, torch::kLong).clone());
  };
  const int64_t N = job.training_count, held_out = job.validation_count;
  const torch::Tensor xt = select(x_all, job.training_rows, N), yt = select(y_all, job.training_rows, N);
  const torch::Tensor xv = held_out > 0 ? select(x_all, job.validation_rows, held_out) : torch::Tensor();
  const torch::Tensor yv = held_out > 0 ? select(y_all, job.validation_rows, held_out) : torch::Tensor();

  torch::optim::Adam adam(model->parameters(), torch::optim::AdamOptions(job.learning_rate));
  std::mt19937_64 rng(job.seed);
  std::vector<int64_t> order(static_cast<size_t>(N));
  std::iota(order.begin(), order.end(), 0);
  std::vector<torch::Tensor> kept;  // the parameters of the epoch with the lowest held-out loss
  double best = std::numeric_limits<double>::infinity();
  for (int epoch = 1; epoch <= job.epochs; ++epoch) {
    std::shuffle(order.begin(), order.end(), rng);
    const torch::Tensor perm = torch::from_blob(order.data(), {N}, torch::kLong).clone();
    double total = 0.0;
    for (int64_t start = 0; start < N; start += job.batch_size) {
      const int64_t stop = std::min<int64_t>(N, start + job.batch_size);
      const torch::Tensor idx = perm.slice(0, start, stop);
      adam.zero_grad();
      const torch::Tensor loss = torch::mse_loss(model->forward(xt.index_select(0, idx)), yt.index_select(0, idx));
      loss.backward();
      adam.step();
      total += loss.item<double>() * static_cast<double>(stop - start);
    }
    const double training_loss = total / static_cast<double>(N);
    outcome.epochs_run = epoch;
    bool stop = false;
    if (held_out == 0) {
      outcome.training_loss = training_loss;
      outcome.kept_epoch = epoch;
    } else {
      torch::NoGradGuard no_grad;
      const double validation = torch::mse_loss(model->forward(xv), yv).item<double>();
      if (validation < best) {  // NaN never improves: a diverged run keeps its last good epoch
        best = validation;
        outcome.training_loss = training_loss;
        outcome.validation_loss = validation;
        outcome.kept_epoch = epoch;
        kept.clear();
        for (const auto& p : model->parameters()) kept.push_back(p.detach().clone());
      }
      stop = epoch - outcome.kept_epoch >= job.patience;
    }
    if (job.epoch_done) job.epoch_done(job.context, epoch, training_loss);
    if (stop) break;
  }
  if (held_out > 0) {
    if (kept.empty()) {  // no epoch gave a finite held-out loss
      outcome.training_loss = std::numeric_limits<double>::quiet_NaN();
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
      job.layer(job.context, w.data_ptr<double>(), static_cast<int>(w.size(0)), static_cast<int>(w.size(1)),
                b.data_ptr<double>());
    }
  }
}

}  // namespace

extern "C" __attribute__((visibility("default"))) int gipdyn_network_plugin_abi() { return GIPDYN_NETWORK_PLUGIN_ABI; }

extern "C" __attribute__((visibility("default"))) int gipdyn_train_network(const GipdynNetworkJob* job,
                                                                            GipdynNetworkOutcome* outcome) {
  outcome->epochs_run = 0;
  outcome->kept_epoch = 0;
  outcome->training_loss = std::numeric_limits<double>::quiet_NaN();
  outcome->validation_loss = std::numeric_limits<double>::quiet_NaN();
  outcome->error[0] = '\0';
  try {
    train(*job, *outcome);
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(outcome->error, sizeof outcome->error, "libtorch: %s", e.what());
  } catch (...) {
    std::snprintf(outcome->error, sizeof outcome->error, "libtorch failed without a message");
  }
  return 1;
}
