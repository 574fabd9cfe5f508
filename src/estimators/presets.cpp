#include "gipdyn/estimators/presets.hpp"

#include "gipdyn/error.hpp"

namespace gipdyn {

const std::vector<std::string>& preset_names() {
  static const std::vector<std::string> names{"default", "real"};
  return names;
}

EstimatorOptions preset_options(const std::string& name) {
  require_one_of(name, preset_names(), "preset");
  EstimatorOptions o;
  if (name == "real") o.name = "gip-envelope+friction";
  return o;
}

int preset_max_training_rows(const std::string& name) {
  require_one_of(name, preset_names(), "preset");
  // docs/real-robots.md: on the UR10 and SARCOS learning curves gip-envelope gains
  // little beyond 1000 rows, and 1000 rows train in about a minute per joint on one core.
  return name == "real" ? 1000 : 0;
}

}  // namespace gipdyn
