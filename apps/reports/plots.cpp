#include "reports/plots.hpp"

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "plot_script.inc"  // kPlotScript, generated from plots.py by CMake

namespace gipdyn {
namespace {

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string python() {
  if (const char* p = std::getenv("GIPDYN_PYTHON"); p && *p) return p;
  return std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
}

}  // namespace

const char* plot_script() { return kPlotScript; }

PlotResult render_plot(const std::string& kind, const std::string& input, const std::string& png) {
  PlotResult r;
  const std::string tmp = png + ".tmp.png";
  // The script arrives on stdin; whatever python prints, on either stream, goes to a file for the
  // message instead of the user's terminal.
  const std::string log = png + ".log";
  const std::string cmd =
      python() + " - " + quoted(kind) + " " + quoted(input) + " " + quoted(tmp) + " > " + quoted(log) + " 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "w");
  if (!pipe) {
    r.message = "could not start " + python() + " to draw " + png;
    return r;
  }
  std::fwrite(kPlotScript, 1, std::strlen(kPlotScript), pipe);
  const int status = ::pclose(pipe);
  std::string output;
  if (FILE* f = std::fopen(log.c_str(), "r")) {
    char buf[512];
    while (std::fgets(buf, sizeof buf, f)) output = buf;  // the last line says why
    std::fclose(f);
  }
  std::error_code ec;
  std::filesystem::remove(log, ec);
  if (status != 0 || !std::filesystem::exists(tmp)) {
    std::filesystem::remove(tmp, ec);
    while (!output.empty() && (output.back() == '\n' || output.back() == '\r')) output.pop_back();
    // Only a python that cannot run the script at all is fixed by installing something; a script
    // that fails on its input is our bug, and its last line says where.
    const bool no_matplotlib = output.empty() || output.find("No module named") != std::string::npos ||
                               WIFEXITED(status) == 0 || WEXITSTATUS(status) == 127;
    if (no_matplotlib)
      r.message = "no plot " + png + " (" + (output.empty() ? "python failed" : output) +
                  "); install python3-matplotlib or set GIPDYN_PYTHON to a python with matplotlib";
    else
      r.message = "no plot " + png + ": the plotting script failed on its input (" + output +
                  "); the data files beside it are complete; please report this";
    return r;
  }
  std::filesystem::rename(tmp, png, ec);
  if (ec) {
    r.message = "could not write " + png + ": " + ec.message();
    return r;
  }
  r.ok = true;
  return r;
}

}  // namespace gipdyn
