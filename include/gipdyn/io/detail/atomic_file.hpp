#pragma once
// Output files appear whole or not at all: content goes to a temporary file in
// the target's directory, is flushed and fsync'ed, and only then renamed over
// the target. A group of files (a CSV and its JSON sidecar) is written the same
// way: every temporary first, the renames last, in the order given, so a
// failure while writing leaves every old file as it was.
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace gipdyn {

struct FileContent {
  std::string path;
  std::function<void(std::ostream&)> write;
  bool binary = false;
};

// Writes every file's temporary, then renames them in order (put a sidecar
// last). If any write throws or fails, every temporary is removed, no target
// changes, and gipdyn::Error is thrown. Temporaries that a killed gipdyn left
// next to a target (".NAME.tmp.PID" of a process that no longer runs) are removed.
void write_files_atomically(const std::vector<FileContent>& files);

// One file.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary = false);

}  // namespace gipdyn
