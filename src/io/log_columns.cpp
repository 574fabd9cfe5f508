#include "gipdyn/io/log_columns.hpp"

#include <algorithm>
#include <fstream>
#include <limits>
#include <map>

#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"

namespace gipdyn {
namespace {

constexpr const char* kFromOne = "{i}";
constexpr const char* kFromZero = "{i0}";
constexpr const char* kForm = "quantity=pattern pairs separated by commas, e.g. q=position_{i0},qd=velocity_{i0},"
                              "tau=effort_{i0} ({i}: the joint's number from 1, {i0}: from 0), or a JSON file of them";

// A pattern split around its one placeholder.
struct Pattern {
  std::string prefix, suffix;
  int first = 1;  // the number the first joint has
};

int count(const std::string& text, const std::string& part) {
  int found = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + part.size())) ++found;
  return found;
}

Pattern split_pattern(const std::string& pattern) {
  Pattern p;
  size_t at = pattern.find(kFromZero);
  size_t width = std::string(kFromZero).size();
  p.first = 0;
  if (at == std::string::npos) {
    at = pattern.find(kFromOne);
    width = std::string(kFromOne).size();
    p.first = 1;
  }
  p.prefix = pattern.substr(0, at);
  p.suffix = pattern.substr(at + width);
  return p;
}

const std::string& field(const LogColumns& c, size_t k) {
  const std::string* fields[] = {&c.q, &c.qd, &c.qdd, &c.tau};
  return *fields[k];
}

std::string& field(LogColumns& c, size_t k) {
  std::string* fields[] = {&c.q, &c.qd, &c.qdd, &c.tau};
  return *fields[k];
}

}  // namespace

const std::vector<std::string>& log_column_quantities() {
  static const std::vector<std::string> quantities = {"q", "qd", "qdd", "tau"};
  return quantities;
}

std::optional<JointColumn> split_joint_column(const std::string& name) {
  const size_t digits = name.find_first_of("0123456789");
  if (digits == std::string::npos || name.find_first_not_of("0123456789", digits) != std::string::npos)
    return std::nullopt;
  const auto& quantities = log_column_quantities();
  const std::string quantity = name.substr(0, digits);
  if (std::find(quantities.begin(), quantities.end(), quantity) == quantities.end()) return std::nullopt;
  // More digits than an int holds name no joint a robot has: the largest number stands for them.
  const std::string number = name.substr(digits);
  return JointColumn{quantity, number.size() > 9 ? std::numeric_limits<int>::max() : std::stoi(number)};
}

void LogColumns::validate() const {
  const auto& quantities = log_column_quantities();
  for (size_t k = 0; k < quantities.size(); ++k) {
    const std::string& pattern = field(*this, k);
    if (count(pattern, kFromOne) + count(pattern, kFromZero) != 1)
      throw Error("LogColumns::" + quantities[k] + " ('" + pattern + "') must hold exactly one {i} (the joint's number "
                  "from 1) or {i0} (from 0), e.g. position_{i0}");
    for (size_t other = 0; other < k; ++other)
      if (field(*this, other) == pattern)
        throw Error("LogColumns::" + quantities[other] + " and LogColumns::" + quantities[k] + " are both ('" +
                    pattern + "'): each quantity needs its own columns");
  }
}

bool LogColumns::is_default() const {
  const LogColumns ours;
  return q == ours.q && qd == ours.qd && qdd == ours.qdd && tau == ours.tau;
}

std::string LogColumns::log_name(const std::string& quantity, int joint) const {
  const auto& quantities = log_column_quantities();
  for (size_t k = 0; k < quantities.size(); ++k)
    if (quantities[k] == quantity) {
      const Pattern p = split_pattern(field(*this, k));
      return p.prefix + std::to_string(joint - 1 + p.first) + p.suffix;
    }
  throw Error("unknown log quantity '" + quantity + "': one of q, qd, qdd, tau");
}

std::vector<std::string> LogColumns::renamed(const std::vector<std::string>& names, const std::string& path) const {
  if (is_default()) return names;
  const auto& quantities = log_column_quantities();
  std::vector<Pattern> patterns;
  for (size_t k = 0; k < quantities.size(); ++k) patterns.push_back(split_pattern(field(*this, k)));
  const LogColumns ours;
  std::vector<std::string> out = names;
  for (auto& name : out) {
    // A placeholder matches digits; where several patterns match, the one with the longest fixed part
    // (prefix and suffix) wins, so that no column is read as two quantities.
    size_t best_fixed = 0;
    std::string best;
    for (size_t k = 0; k < quantities.size(); ++k) {
      const Pattern& p = patterns[k];
      if (name.size() <= p.prefix.size() + p.suffix.size()) continue;
      if (name.compare(0, p.prefix.size(), p.prefix) != 0) continue;
      if (name.compare(name.size() - p.suffix.size(), p.suffix.size(), p.suffix) != 0) continue;
      const std::string digits = name.substr(p.prefix.size(), name.size() - p.prefix.size() - p.suffix.size());
      if (digits.empty() || digits.size() > 4 ||
          digits.find_first_not_of("0123456789") != std::string::npos)
        continue;
      const int joint = std::stoi(digits) + 1 - p.first;
      if (joint < 1) continue;
      if (p.prefix.size() + p.suffix.size() + 1 > best_fixed) {
        best_fixed = p.prefix.size() + p.suffix.size() + 1;
        best = quantities[k] + std::to_string(joint);
      }
    }
    if (!best.empty()) {
      name = best;
      continue;
    }
    // gipdyn's own name of a quantity the patterns rename is not that quantity here: reading it
    // as such would take a column the patterns say is something else.
    const std::optional<JointColumn> ours_named = split_joint_column(name);
    for (size_t k = 0; k < quantities.size() && ours_named; ++k)
      if (field(*this, k) != field(ours, k) && ours_named->quantity == quantities[k])
        throw Error("'" + path + "' has a column '" + name + "', gipdyn's name of a joint's " + quantities[k] +
                    ", but LogColumns::" + quantities[k] + " says the log calls them " + field(*this, k) +
                    ": leave LogColumns::" + quantities[k] + " at gipdyn's name, or rename that column");
  }
  // Two columns under one name: two that a pattern maps to the same joint, or a column the log already
  // calls by one of gipdyn's names beside one renamed to it.
  for (size_t a = 0; a < out.size(); ++a)
    for (size_t b = a + 1; b < out.size(); ++b)
      if (!out[a].empty() && out[a] == out[b])
        throw Error("'" + path + "': columns '" + names[a] + "' and '" + names[b] + "' would both be " + out[a] +
                    " under the log's column names (LogColumns); remove one, or give patterns that tell them apart");
  return out;
}

LogColumns parse_log_columns(const std::string& spec) {
  LogColumns columns;
  if (spec.empty()) return columns;
  const auto& quantities = log_column_quantities();
  std::map<std::string, std::string> pairs;
  const bool is_file = spec.find('=') == std::string::npos;
  if (is_file) {
    std::ifstream in(spec);
    if (!in)
      throw Error("log columns '" + spec + "' are neither " + std::string(kForm) + " nor a readable file");
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      throw Error("'" + spec + "' is not a JSON object of log column patterns, e.g. {\"q\": \"position_{i0}\", "
                  "\"tau\": \"effort_{i0}\"}");
    for (const auto& [key, value] : j.items()) {
      if (!value.is_string()) throw Error("'" + spec + "': the pattern of '" + key + "' must be a string");
      pairs[key] = value.get<std::string>();
    }
  } else {
    size_t start = 0;
    while (start <= spec.size()) {
      const size_t end = std::min(spec.find(',', start), spec.size());
      const std::string item = spec.substr(start, end - start);
      const size_t eq = item.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == item.size())
        throw Error("log columns '" + spec + "': '" + item + "' is not quantity=pattern; expected " + kForm);
      const std::string key = item.substr(0, eq);
      if (!pairs.emplace(key, item.substr(eq + 1)).second)
        throw Error("log columns '" + spec + "' name " + key + " twice");
      start = end + 1;
    }
  }
  for (const auto& [key, pattern] : pairs) {
    size_t k = 0;
    while (k < quantities.size() && quantities[k] != key) ++k;
    if (k == quantities.size())
      throw Error("log columns '" + spec + "': unknown quantity '" + key + "'; the quantities are q, qd, qdd and tau");
    field(columns, k) = pattern;
  }
  columns.validate();
  return columns;
}

}  // namespace gipdyn
