#pragma once
// The command line's names for the library's fields: library errors name
// `SearchSettings::min_noise_fraction`, the user typed `--min-noise`.
#include <string>
#include <vector>

#include "gipdyn/error.hpp"

namespace gipdyn::cli {

const FieldNames& cli_field_names();

// One "gipdyn: warning: ..." line on stderr per message, library field names
// in their command-line spelling.
void print_warnings(const std::vector<std::string>& warnings);

}  // namespace gipdyn::cli
