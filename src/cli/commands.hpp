#pragma once
// Sub-commands of the `gipdyn` executable. Each registers its options on the
// CLI11 app and returns the function that runs it.
#include <CLI/CLI.hpp>
#include <functional>

namespace gipdyn::cli {

using Command = std::function<int()>;

Command add_train(CLI::App& app);
Command add_predict(CLI::App& app);
Command add_evaluate(CLI::App& app);
Command add_simulate(CLI::App& app);
Command add_experiment(CLI::App& app);
Command add_preprocess(CLI::App& app);

}  // namespace gipdyn::cli
