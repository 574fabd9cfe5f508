#include "gipdyn/io/detail/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "gipdyn/error.hpp"

namespace gipdyn {

namespace {

namespace fs = std::filesystem;

fs::path directory_of(const fs::path& target) {
  return target.has_parent_path() ? target.parent_path() : fs::path(".");
}

std::string temporary_prefix(const fs::path& target) { return "." + target.filename().string() + ".tmp."; }

// ".NAME.tmp.PID" files of processes that are gone: a run killed mid-write.
void remove_stale_temporaries(const fs::path& target) {
  const std::string prefix = temporary_prefix(target);
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory_of(target), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string pid_text = name.substr(prefix.size());
    if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos) continue;
    const long pid = std::stol(pid_text);
    if (pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == -1 && errno == ESRCH) {
      std::error_code ignore;
      fs::remove(entry.path(), ignore);
    }
  }
}

// The data must be on disk before the rename makes it the target.
bool sync_path(const fs::path& p, int flags) {
  const int fd = ::open(p.c_str(), flags);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
}

}  // namespace

void write_files_atomically(const std::vector<FileContent>& files) {
  std::vector<fs::path> temporaries;
  auto discard = [&] {
    std::error_code ignore;
    for (const auto& t : temporaries) fs::remove(t, ignore);
  };
  try {
    for (const FileContent& f : files) {
      const fs::path target(f.path);
      const fs::path dir = directory_of(target);
      if (!fs::is_directory(dir))
        throw Error("cannot write '" + f.path + "': directory '" + dir.string() + "' does not exist");
      remove_stale_temporaries(target);
      const fs::path tmp = dir / (temporary_prefix(target) + std::to_string(::getpid()));
      temporaries.push_back(tmp);
      {
        std::ofstream out(tmp, f.binary ? std::ios::binary | std::ios::trunc : std::ios::trunc);
        if (!out) throw Error("cannot write '" + f.path + "': " + std::strerror(errno));
        f.write(out);
        out.flush();
        if (!out) throw Error("cannot write '" + f.path + "': write failed (disk full?)");
      }
      if (!sync_path(tmp, O_RDONLY)) throw Error("cannot write '" + f.path + "': fsync failed: " + std::strerror(errno));
    }
    for (size_t k = 0; k < files.size(); ++k) {
      std::error_code ec;
      fs::rename(temporaries[k], files[k].path, ec);
      if (ec) throw Error("cannot write '" + files[k].path + "': " + ec.message());
      temporaries[k].clear();
    }
  } catch (...) {
    discard();
    throw;
  }
  // The renames themselves reach the disk with the directory.
  for (const FileContent& f : files) sync_path(directory_of(fs::path(f.path)), O_RDONLY | O_DIRECTORY);
}

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write, bool binary) {
  write_files_atomically({FileContent{path, write, binary}});
}

}  // namespace gipdyn
