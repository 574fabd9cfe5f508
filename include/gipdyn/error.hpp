#pragma once
// Errors that reach a user: one line that names the problem and the fix.
#include <stdexcept>
#include <string>

namespace gipdyn {

// Thrown for bad input (files, options, data). Numerical routines do not throw;
// they return a status (see gp/cholesky.hpp, optim/optimizer.hpp).
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace gipdyn
