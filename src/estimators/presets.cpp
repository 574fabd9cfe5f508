#include "gipdyn/estimators/presets.hpp"

#include "gipdyn/error.hpp"

namespace gipdyn {

const std::vector<std::string>& preset_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const EstimatorSpec& e : estimator_table())
      if (!e.preset.empty()) n.push_back(e.preset);
    return n;
  }();
  return names;
}

EstimatorOptions preset_options(const std::string& name) {
  require_one_of(name, preset_names(), "preset");
  EstimatorOptions o;
  for (const EstimatorSpec& e : estimator_table())
    if (e.preset == name) o.name = e.name;
  return o;
}

int preset_max_training_rows(const std::string& name) {
  require_one_of(name, preset_names(), "preset");
  for (const EstimatorSpec& e : estimator_table())
    if (e.preset == name) return e.preset_max_training_rows;
  return 0;
}

}  // namespace gipdyn
