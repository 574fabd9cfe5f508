#include "output_guard.hpp"

#include <filesystem>

#include "gipdyn/error.hpp"

namespace gipdyn::cli {

void refuse_overwriting_inputs(const std::vector<std::pair<std::string, std::string>>& inputs,
                               const std::vector<std::pair<std::string, std::string>>& outputs) {
  namespace fs = std::filesystem;
  for (const auto& [out_flag, out_path] : outputs) {
    if (out_path.empty()) continue;
    for (const auto& [in_flag, in_path] : inputs) {
      std::error_code ec;
      // Only an existing output can be an existing input; equivalent() compares device and inode.
      if (!in_path.empty() && fs::equivalent(fs::path(in_path), fs::path(out_path), ec) && !ec)
        throw Error(out_flag + " '" + out_path + "' is the same file as " + in_flag + " '" + in_path +
                    "'; writing it would destroy the input: choose another " + out_flag);
    }
  }
}

}  // namespace gipdyn::cli
