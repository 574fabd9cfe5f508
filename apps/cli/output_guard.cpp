#include "output_guard.hpp"

#include <filesystem>

#include "gipdyn/error.hpp"

namespace gipdyn::cli {

namespace {

namespace fs = std::filesystem;

// Outputs need not exist yet, so equivalent() alone cannot compare them.
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::equivalent(fs::path(a), fs::path(b), ec) && !ec) return true;
  auto resolved = [](const std::string& p) {
    std::error_code e;
    const fs::path r = fs::weakly_canonical(fs::path(p), e);
    return e ? fs::absolute(fs::path(p)).lexically_normal() : r;
  };
  return resolved(a) == resolved(b);
}

}  // namespace

void refuse_overwrites(const std::vector<std::pair<std::string, std::string>>& inputs,
                       const std::vector<std::pair<std::string, std::string>>& outputs) {
  for (size_t k = 0; k < outputs.size(); ++k) {
    const auto& [out_flag, out_path] = outputs[k];
    if (out_path.empty()) continue;
    for (const auto& [in_flag, in_path] : inputs) {
      std::error_code ec;
      // Only an existing output can be an existing input; equivalent() compares device and inode.
      if (!in_path.empty() && fs::equivalent(fs::path(in_path), fs::path(out_path), ec) && !ec)
        throw Error(out_flag + " '" + out_path + "' is the same file as " + in_flag + " '" + in_path +
                    "'; writing it would destroy the input: choose another " + out_flag);
    }
    for (size_t earlier = 0; earlier < k; ++earlier) {
      const auto& [other_flag, other_path] = outputs[earlier];
      if (!other_path.empty() && same_file(out_path, other_path))
        throw Error(out_flag + " and " + other_flag + " name the same file '" + out_path +
                    "': one would overwrite the other; give " + out_flag + " a file of its own");
    }
  }
}

}  // namespace gipdyn::cli
