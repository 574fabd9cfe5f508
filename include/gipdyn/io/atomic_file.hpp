#pragma once
// Output files appear whole or not at all: content goes to a temporary file in
// the same directory, which is flushed and renamed over the target.
#include <functional>
#include <ostream>
#include <string>

namespace gipdyn {

// Calls write(stream) on a temporary file next to `path`, then renames it to
// `path`. If write throws or the stream fails, the temporary file is removed,
// `path` is left untouched and gipdyn::Error is thrown.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary = false);

}  // namespace gipdyn
