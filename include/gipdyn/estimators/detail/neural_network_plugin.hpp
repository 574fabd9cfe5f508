#pragma once
// The boundary between the library and its libtorch plugin. libtorch trains
// the nn estimator's network and nothing else, yet loading it costs a process
// about a second and hundreds of shared libraries. So it lives in a plugin
// (libgipdyn_torch.so, src/estimators/neural_network_torch.cpp) that the
// library opens the first time a network is trained
// (estimators/neural_network.cpp): every other command, the Python module and
// a control loop linking the C API start without it.
//
// Plain C types only, so that the two sides share no C++ object layout.

extern "C" {

// Raised whenever the structs below change: a plugin of another version is refused.
#define GIPDYN_NETWORK_PLUGIN_ABI 2

struct GipdynNetworkJob {
  // Standardised training data, row-major: rows x inputs and rows x outputs.
  const double* x;
  const double* y;
  long long rows;
  int inputs;
  int outputs;
  // The rows the network learns from, and those whose loss chooses the epoch
  // kept (none: the last epoch is kept).
  const long long* training_rows;
  long long training_count;
  const long long* validation_rows;
  long long validation_count;
  const int* hidden;  // units of each hidden layer (sigmoid), then a linear output layer
  int hidden_layers;
  unsigned long long seed;
  double learning_rate;
  int epochs;
  int batch_size;
  int patience;  // with validation rows: epochs without a lower held-out loss before stopping
  int threads;
  // The caller's callbacks, each given `context`. epoch_done: after every
  // epoch (may be null). layer: once per layer of the kept network, input
  // layer first; W is rows x cols row-major, b has rows entries.
  void* context;
  void (*epoch_done)(void* context, int epoch, double training_loss);
  void (*layer)(void* context, const double* W, int rows, int cols, const double* b);
};

struct GipdynNetworkOutcome {
  int epochs_run;
  int kept_epoch;
  double training_loss;    // of the kept epoch (NaN where no epoch had a finite held-out loss)
  double validation_loss;  // of the kept epoch; NaN without validation rows
  char error[512];         // why training failed, where gipdyn_train_network returned non-zero
};

// Both exported by the plugin.
typedef int (*GipdynNetworkPluginAbi)(void);
typedef int (*GipdynTrainNetwork)(const struct GipdynNetworkJob* job, struct GipdynNetworkOutcome* outcome);
}
