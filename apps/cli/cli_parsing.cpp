#include "cli_parsing.hpp"

#include <sstream>

#include "gipdyn/error.hpp"

namespace gipdyn::cli {

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

std::vector<int> parse_int_list(const std::string& text, const std::string& flag, const std::string& example) {
  std::vector<int> out;
  for (const auto& item : split_list(text)) {
    size_t used = 0;
    int v = 0;
    try {
      v = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size())
      throw Error(flag + ": '" + item + "' is not a whole number; write e.g. " + example);
    out.push_back(v);
  }
  return out;
}

std::pair<long, long> parse_row_range(const std::string& text, const std::string& flag) {
  const auto dash = text.find('-');
  try {
    if (dash != std::string::npos) {
      size_t used1 = 0, used2 = 0;
      const long a = std::stol(text.substr(0, dash), &used1), b = std::stol(text.substr(dash + 1), &used2);
      if (used1 == dash && used2 == text.size() - dash - 1 && a >= 1 && b >= a) return {a, b};
    }
  } catch (const std::exception&) {
  }
  throw Error(flag + " '" + text + "' is not a row range; write FIRST-LAST with 1-based data rows, e.g. 1-6340");
}

}  // namespace gipdyn::cli
