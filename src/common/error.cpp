#include "gipdyn/error.hpp"

#include <algorithm>

namespace gipdyn {

std::string joined(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (size_t k = 0; k < items.size(); ++k) out += (k ? separator : "") + items[k];
  return out;
}

std::string joint_numbers(const std::vector<std::ptrdiff_t>& zero_based) {
  std::vector<std::string> numbers;
  for (std::ptrdiff_t j : zero_based) numbers.push_back(std::to_string(j + 1));
  return joined(numbers);
}

void require_one_of(const std::string& name, const std::vector<std::string>& names, const std::string& what) {
  if (std::find(names.begin(), names.end(), name) != names.end()) return;
  throw Error("unknown " + what + " '" + name + "'; choose one of: " + joined(names));
}

std::string rename_fields(const std::string& message, const FieldNames& names) {
  std::vector<const std::pair<std::string, std::string>*> order;
  for (const auto& n : names) order.push_back(&n);
  std::stable_sort(order.begin(), order.end(),
                   [](const auto* a, const auto* b) { return a->first.size() > b->first.size(); });
  // Mark replaced spans so that a front-end name is never rewritten again.
  std::string out = message;
  std::vector<bool> done(out.size(), false);
  for (const auto* n : order) {
    if (n->first.empty()) continue;
    for (size_t pos = out.find(n->first); pos != std::string::npos; pos = out.find(n->first, pos)) {
      if (std::any_of(done.begin() + static_cast<long>(pos), done.begin() + static_cast<long>(pos + n->first.size()),
                      [](bool b) { return b; })) {
        pos += n->first.size();
        continue;
      }
      out.replace(pos, n->first.size(), n->second);
      done.erase(done.begin() + static_cast<long>(pos), done.begin() + static_cast<long>(pos + n->first.size()));
      done.insert(done.begin() + static_cast<long>(pos), n->second.size(), true);
      pos += n->second.size();
    }
  }
  return out;
}

}  // namespace gipdyn
