#pragma once
// PNG plots, drawn by matplotlib: the plotting script is compiled into the
// application and run with Debian's /usr/bin/python3 (or $GIPDYN_PYTHON), so a
// missing matplotlib costs the pictures, never the numbers.
#include <string>

namespace gipdyn {

struct PlotResult {
  bool ok = false;
  std::string message;  // why no PNG was written, with the fix
};

// kind: boxplot (nmse.csv), gmse (gmse.csv), bars (nmse.csv of one split),
// timeseries (predictions CSV), residuals (predictions CSV with *_hat),
// noise-ratio (diagnostics JSON), motion (true and learned positions from
// `simulate --model`), tracking (errors.csv of the control experiment),
// physics (physics.csv of `evaluate --physics`), learning_curve
// (learning_curve.csv of `experiment real --sizes`), consistency (the JSON
// report of `inspect`), contacts (the CSV of `detect`).
// Writes `png` atomically.
PlotResult render_plot(const std::string& kind, const std::string& input, const std::string& png);

// The embedded script, for users who want to restyle the plots.
const char* plot_script();

}  // namespace gipdyn
