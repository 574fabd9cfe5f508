#pragma once
// The command line's names for the library's fields: library errors name
// `TrainOptions::min_noise_fraction`, the user typed `--min-noise`.
#include "gipdyn/error.hpp"

namespace gipdyn::cli {

const FieldNames& cli_field_names();

}  // namespace gipdyn::cli
