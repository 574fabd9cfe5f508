#pragma once
// Outputs that would destroy inputs or each other: `train --data d.csv --out
// d.csv` and `train --out m --teacher-out m` must fail before any work,
// naming both flags.
#include <string>
#include <utility>
#include <vector>

namespace gipdyn::cli {

// (flag, path) pairs; empty paths are options not given. Throws gipdyn::Error
// if an output is the same file as an input, or as another output. Links and
// other spellings of a path count: paths are compared with their symbolic
// links resolved, and existing files by device and inode.
void refuse_overwrites(const std::vector<std::pair<std::string, std::string>>& inputs,
                       const std::vector<std::pair<std::string, std::string>>& outputs);

}  // namespace gipdyn::cli
