#include "gipdyn/progress.hpp"

#include <cmath>
#include <cstdio>

namespace gipdyn {

std::string describe(const ProgressEvent& e) {
  std::string line = e.estimator;
  auto add = [&line](const std::string& s) { line += (line.empty() ? "" : " ") + s; };
  if (e.joint >= 0) add("joint " + std::to_string(e.joint + 1));
  char buf[160];
  if (e.finished && e.iteration == 0) {  // a whole fit: its outcome and time
    std::snprintf(buf, sizeof buf, " (%.1f s)", e.seconds);
    add(e.message + buf);
    return line;
  }
  if (e.finished) {
    std::snprintf(buf, sizeof buf, "done after %d iterations (%.1f s)", e.iteration, e.seconds);
    add(buf);
    if (std::isfinite(e.objective)) {
      std::snprintf(buf, sizeof buf, ": objective %.6g", e.objective);
      line += buf;
    }
    if (!e.message.empty()) line += (std::isfinite(e.objective) ? ", " : ": ") + e.message;
    return line;
  }
  if (e.iteration == 0) {  // a note
    add(e.message);
    return line;
  }
  if (e.rows > 0) add("on " + std::to_string(e.rows) + " rows");
  if (e.restart > 0) add("restart " + std::to_string(e.restart));
  std::snprintf(buf, sizeof buf, "iteration %d: objective %.6g", e.iteration, e.objective);
  add(buf);
  if (std::isfinite(e.grad_norm)) {
    std::snprintf(buf, sizeof buf, " |grad| %.3g", e.grad_norm);
    line += buf;
  }
  std::snprintf(buf, sizeof buf, " (%.1f s)", e.seconds);
  line += buf;
  return line;
}

void send_note(const ProgressCallback& progress, const std::string& estimator, const std::string& message) {
  if (!progress) return;
  ProgressEvent e;
  e.estimator = estimator;
  e.message = message;
  progress(e);
}

}  // namespace gipdyn
