#pragma once
// The exit status of every command, as scripts and shells expect it
// (docs/reference/cli.md, "Exit codes"), and the error line that goes with it.
#include <iostream>
#include <string>

namespace gipdyn::cli {

// Everything asked for was done.
inline constexpr int kExitSuccess = 0;
// Anything else went wrong: bad data, a fit that failed, a plot not drawn
// (its numbers are written), an experiment with failed fits (the rest stand).
// The message on stderr says what and how to fix it.
inline constexpr int kExitFailure = 1;
// The command line itself: an unknown command or option, an option's value
// that is not of its type, a required option missing, a file an option names
// that does not exist.
inline constexpr int kExitUsage = 2;

// Writes "gipdyn: error: MESSAGE" and its newline in one write: under mpiexec,
// whose own messages share the terminal, a line written in pieces came out
// split by them.
inline void print_error(const std::string& message) { std::cerr << ("gipdyn: error: " + message + "\n") << std::flush; }

}  // namespace gipdyn::cli
