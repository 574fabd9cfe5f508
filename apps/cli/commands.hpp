#pragma once
// Sub-commands of the `gipdyn` executable, one file each. Each registers its
// options on the CLI11 app and returns the function that runs it.
#include <CLI/CLI.hpp>
#include <functional>

namespace gipdyn::cli {

using Command = std::function<int()>;

Command add_train(CLI::App& app);       // train_command.cpp
Command add_predict(CLI::App& app);     // predict_command.cpp
Command add_evaluate(CLI::App& app);    // evaluate_command.cpp
Command add_simulate(CLI::App& app);    // simulate_command.cpp
Command add_preprocess(CLI::App& app);  // preprocess_command.cpp
Command add_physics(CLI::App& app);     // physics_command.cpp
Command add_detect(CLI::App& app);      // detect_command.cpp
Command add_update(CLI::App& app);      // update_command.cpp
Command add_experiment(CLI::App& app);  // experiment_commands.cpp
Command add_inspect(CLI::App& app);     // inspect_command.cpp

}  // namespace gipdyn::cli
