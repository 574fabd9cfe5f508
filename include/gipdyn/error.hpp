#pragma once
// Errors that reach a user: one line that names the problem and the fix.
//
// The library's messages name the field or argument at fault in C++ terms
// (`SearchSettings::min_noise_fraction must be > 0`), never a front end's
// spelling: the command line and the Python module translate those names into
// their own (`--min-noise`, `min_noise=`) with rename_fields.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace gipdyn {

// Thrown for bad input (files, options, data). Numerical routines do not throw;
// they return a status (see gp/cholesky.hpp, optim/optimizer.hpp, model/fit_report.hpp).
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// "a, b, c": the items of a message's list.
std::string joined(const std::vector<std::string>& items, const std::string& separator = ", ");
// "1, 3": zero-based joint indices as the one-based joint numbers messages use.
std::string joint_numbers(const std::vector<std::ptrdiff_t>& zero_based);

// Throws "unknown WHAT 'name'; choose one of: a, b, c" unless name is in names.
void require_one_of(const std::string& name, const std::vector<std::string>& names, const std::string& what);

// A library field name and a front end's name for it, e.g. {"SearchSettings::restarts", "--restarts"}.
using FieldNames = std::vector<std::pair<std::string, std::string>>;

// The message with every library field name of `names` replaced by the front
// end's name. Longer library names are replaced first, so a name that is a
// prefix of another does not break it.
std::string rename_fields(const std::string& message, const FieldNames& names);

}  // namespace gipdyn
