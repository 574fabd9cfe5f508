#pragma once
// Option text the command line parses itself: comma lists and row ranges.
// Errors name the flag and show the expected form.
#include <string>
#include <utility>
#include <vector>

namespace gipdyn::cli {

// "a,b,,c" -> {"a", "b", "c"}
std::vector<std::string> split_list(const std::string& text);
// "400,400" -> {400, 400}; throws gipdyn::Error naming `flag` with `example`.
std::vector<int> parse_int_list(const std::string& text, const std::string& flag, const std::string& example);
// "1-6340" -> {1, 6340}; 1-based, FIRST <= LAST.
std::pair<long, long> parse_row_range(const std::string& text, const std::string& flag);

}  // namespace gipdyn::cli
