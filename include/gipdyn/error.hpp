#pragma once
// Errors that reach a user: one line that names the problem and the fix.
#include <stdexcept>
#include <string>
#include <vector>

namespace gipdyn {

// Thrown for bad input (files, options, data). Numerical routines do not throw;
// they return a status (see gp/cholesky.hpp, optim/optimizer.hpp).
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// Throws "unknown WHAT 'name'; choose one of: a, b, c" unless name is in names.
inline void require_one_of(const std::string& name, const std::vector<std::string>& names, const std::string& what) {
  for (const auto& n : names)
    if (n == name) return;
  std::string valid;
  for (const auto& n : names) valid += (valid.empty() ? "" : ", ") + n;
  throw Error("unknown " + what + " '" + name + "'; choose one of: " + valid);
}

}  // namespace gipdyn
