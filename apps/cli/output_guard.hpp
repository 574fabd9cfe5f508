#pragma once
// Outputs that would destroy inputs: `train --data d.csv --out d.csv` must
// fail before any work, naming both flags.
#include <string>
#include <utility>
#include <vector>

namespace gipdyn::cli {

// (flag, path) pairs. Throws gipdyn::Error if an output path is the same file
// as an input (same device and inode, so links and other spellings count).
void refuse_overwriting_inputs(const std::vector<std::pair<std::string, std::string>>& inputs,
                               const std::vector<std::pair<std::string, std::string>>& outputs);

}  // namespace gipdyn::cli
