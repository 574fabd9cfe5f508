// gipdyn: learn robot inverse dynamics with Gaussian processes and the GIP kernel.
#include <malloc.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "commands.hpp"
#include "distributed_run.hpp"
#include "exit_codes.hpp"
#include "field_names.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/model_container.hpp"
#include "gipdyn/version.hpp"

namespace {

// What uses the memory differs by command, so does the fix.
std::string out_of_memory_advice(const std::string& command) {
  if (command == "train") return "train on fewer rows (--subsample) or fewer joints at once (--threads 1)";
  if (command == "simulate") return "simulate fewer samples (--samples) and concatenate the files";
  if (command == "experiment")
    return "use fewer training rows (--max-train, --sizes, --train-samples) or one estimator at a time (--models)";
  if (command == "update") return "keep fewer rows (--window)";
  if (command == "predict" || command == "evaluate" || command == "physics" || command == "detect")
    return "split --data into smaller files and run them one after another";
  if (command == "inspect") return "look up fewer rows (--max-queries) or split --data";
  if (command == "preprocess") return "split --data into smaller logs, or resample it with a longer period (--dt)";
  return "give it smaller inputs";
}

// Edits (insertions, deletions, substitutions) that turn a into b.
size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// CLI11 answers a mistyped or missing command with "A subcommand is required".
// Name the word it did not know, the closest command and the commands there
// are; "" where CLI11's own message is the right one (options, a known command).
std::string command_error(const CLI::App& app, int argc, char** argv) {
  const CLI::App* level = &app;
  std::string path = "gipdyn";
  const auto commands_of = [](const CLI::App* a) {
    return a->get_subcommands([](const CLI::App*) { return true; });
  };
  const auto names_of = [&](const CLI::App* a) {
    std::string names;
    for (const CLI::App* sub : commands_of(a)) names += (names.empty() ? "" : ", ") + sub->get_name();
    return names;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-' || commands_of(level).empty()) return "";
    const CLI::App* next = nullptr;
    std::string closest;
    size_t best = 3;  // suggest only a command within two edits
    for (const CLI::App* sub : commands_of(level)) {
      if (sub->get_name() == word) next = sub;
      if (const size_t d = edit_distance(word, sub->get_name()); d < best) {
        best = d;
        closest = sub->get_name();
      }
    }
    if (!next)
      return "unknown command '" + word + "' for " + path +
             (closest.empty() ? "" : " (did you mean '" + closest + "'?)") + "; commands: " + names_of(level) + " (" + path +
             " --help)";
    level = next;
    path += " " + word;
  }
  if (level->get_require_subcommand_min() == 0) return "";
  return path + " needs a command: " + names_of(level) + " (" + path + " --help)";
}

// "gipdyn train --help": the help of the command the words name, for a parse error's advice.
std::string command_help(int argc, char** argv) {
  std::string words = "gipdyn";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') break;
    words += " " + word;
  }
  return words + " --help";
}

// Options that were renamed: the old spelling is refused with the new one, never read as an alias, so that
// a script learns the one vocabulary instead of keeping two.
struct RenamedOption {
  const char* command;  // the first word after gipdyn
  const char* old_name;
  const char* new_name;
};
constexpr RenamedOption kRenamedOptions[] = {
    {"train", "--kernel", "--model"},
    {"experiment", "--estimators", "--models"},
};

// "" or the one-line error for an old option name on this command line.
std::string renamed_option_error(int argc, char** argv) {
  if (argc < 2) return "";
  const std::string command = argv[1];
  for (const RenamedOption& r : kRenamedOptions) {
    if (command != r.command) continue;
    const std::string old_name = r.old_name;
    for (int i = 2; i < argc; ++i) {
      const std::string word = argv[i];
      if (word == old_name || word.rfind(old_name + "=", 0) == 0)
        return "gipdyn " + command + " " + old_name + " is now " + r.new_name + " (same values; " +
               command_help(argc, argv) + ")";
    }
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  // libtorch allocates and frees a few hundred kilobytes per layer and batch
  // while training the nn estimator; with glibc's default 128 KiB pad the
  // heap's top was returned to the system and faulted back in every step
  // (bench/RESULTS.md measures both pads). It costs at most this much resident
  // memory held back after a large free.
  mallopt(M_TOP_PAD, 64 << 20);
  CLI::App app{
      "gipdyn: learn a robot's inverse dynamics (q, qd, qdd -> tau) with Gaussian processes and the\n"
      "Geometrically Inspired Polynomial kernel (Dalla Libera & Carli, RA-L 2019).\n"
      "Run `gipdyn COMMAND --help` for the options of a command."};
  // What the build holds, so that a user (and the tests) can tell whether --distributed will work.
  app.set_version_flag("--version", std::string("gipdyn ") + gipdyn::version() + " (model file format " +
                                        std::to_string(gipdyn::kModelFormatVersion) + ", distributed training: " +
                                        (gipdyn::cli::built_with_mpi() ? "MPI" : "not built") + ")\n" +
                                        gipdyn::build_summary());
  app.require_subcommand(1);
  std::map<CLI::App*, gipdyn::cli::Command> commands;
  auto add = [&](const char* name, const char* help, auto adder) {
    CLI::App* sub = app.add_subcommand(name, help);
    commands[sub] = adder(*sub);
  };
  add("simulate", "Simulate a robot (scara, ur10, URDF or JSON DH file) on a random trajectory: q, qd, qdd, tau",
      gipdyn::cli::add_simulate);
  add("preprocess", "Resample, low-pass (zero phase) and differentiate a raw robot log into a training CSV",
      gipdyn::cli::add_preprocess);
  add("train", "Train a model (one GP per joint) on a CSV of q, qd, qdd, tau", gipdyn::cli::add_train);
  add("predict", "Predict torques and their standard deviations for a CSV of q, qd, qdd", gipdyn::cli::add_predict);
  add("evaluate", "Per-joint MSE, nMSE and the GMSE of a model on a CSV with measured torques",
      gipdyn::cli::add_evaluate);
  add("update", "Add new samples to a GP model, hyperparameters fixed (online learning, optional sliding window)",
      gipdyn::cli::add_update);
  add("inspect",
      "Check a log before training: do rows that visit the same state have the same torque, within the log and "
      "between training and test rows?",
      gipdyn::cli::add_inspect);
  add("physics", "Gravity, inertia matrix, Coriolis and friction torques of a learned model (gip, pp, fe) at given states",
      gipdyn::cli::add_physics);
  add("detect", "Detect contacts and estimate external joint torques from a log's torques and a learned model",
      gipdyn::cli::add_detect);
  add("experiment", "The paper's experiments: accuracy (E1), data-efficiency (E2), real (E3); CSV, summary, PNG",
      gipdyn::cli::add_experiment);
  using gipdyn::cli::kExitFailure;
  if (argc == 1) {  // the overview, as --help prints it
    std::cout << app.help();
    return gipdyn::cli::kExitSuccess;
  }
  if (const std::string error = command_error(app, argc, argv); !error.empty()) {
    gipdyn::cli::print_error(error);
    return gipdyn::cli::kExitUsage;
  }
  if (const std::string error = renamed_option_error(argc, argv); !error.empty()) {
    gipdyn::cli::print_error(error);
    return gipdyn::cli::kExitUsage;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    gipdyn::cli::print_error(std::string(e.what()) + " (" + command_help(argc, argv) + ")");
    return gipdyn::cli::kExitUsage;
  }
  std::string command;
  try {
    for (auto& [sub, run] : commands)
      if (sub->parsed()) {
        command = sub->get_name();
        return run();
      }
  } catch (const gipdyn::cli::ExitQuietly&) {
    return kExitFailure;  // another MPI process reported the error
  } catch (const gipdyn::Error& e) {
    gipdyn::cli::print_error(gipdyn::rename_fields(e.what(), gipdyn::cli::cli_field_names()));
    return kExitFailure;
  } catch (const std::bad_alloc&) {
    gipdyn::cli::print_error("out of memory; " + out_of_memory_advice(command));
    return kExitFailure;
  } catch (const std::exception& e) {
    gipdyn::cli::print_error(e.what());
    return kExitFailure;
  }
  return kExitFailure;
}
