#include "gipdyn/memory.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "gipdyn/error.hpp"

namespace gipdyn {

namespace {

// The first number after `key` in a "key value" file such as /proc/meminfo; 0 if absent.
std::size_t read_field(const char* path, const std::string& key) {
  std::ifstream file(path);
  std::string line;
  while (std::getline(file, line)) {
    std::istringstream fields(line);
    std::string name;
    std::size_t value = 0;
    if (fields >> name >> value && name == key) return value;
  }
  return 0;
}

// The whole content of a one-number file such as cgroup v2's memory.max; 0 if
// absent or "max" (no limit).
std::size_t read_number(const char* path) {
  std::ifstream file(path);
  std::size_t value = 0;
  return (file >> value) ? value : 0;
}

}  // namespace

std::size_t available_memory_bytes() {
  std::size_t available = read_field("/proc/meminfo", "MemAvailable:") * 1024;
  if (available == 0)
    available = static_cast<std::size_t>(::sysconf(_SC_PHYS_PAGES)) * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  // A container (cgroup v2) or a batch scheduler (ulimit -v) may allow far less
  // than the machine has; the allocation fails at the smallest of the limits.
  const std::size_t cgroup_max = read_number("/sys/fs/cgroup/memory.max");
  if (cgroup_max > 0) {
    const std::size_t used = read_number("/sys/fs/cgroup/memory.current");
    available = std::min(available, cgroup_max > used ? cgroup_max - used : 0);
  }
  struct rlimit limit {};
  if (::getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
    const std::size_t mapped = read_field("/proc/self/status", "VmSize:") * 1024;
    const std::size_t cap = static_cast<std::size_t>(limit.rlim_cur);
    available = std::min(available, cap > mapped ? cap - mapped : 0);
  }
  return available;
}

std::string format_bytes(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024.0 && u < 6) {
    bytes /= 1024.0;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", bytes, units[u]);
  return buf;
}

void require_memory(double bytes, const std::string& what, const std::string& fix) {
  const double available = static_cast<double>(available_memory_bytes());
  if (bytes > available)
    throw Error(what + " needs about " + format_bytes(bytes) + " but this machine has " + format_bytes(available) +
                " available; " + fix);
}

}  // namespace gipdyn
