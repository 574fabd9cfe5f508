#pragma once
// Memory checks before big allocations: a typo in a size must give a message
// with the estimate, not a swapping machine or an out-of-memory kill.
#include <cstddef>
#include <string>

namespace gipdyn {

// Bytes this process can still allocate: the smallest of the machine's
// MemAvailable (physical memory where that is unknown), what its cgroup v2
// memory.max leaves, and what its address-space limit (ulimit -v) leaves.
std::size_t available_memory_bytes();

// "1.5 GiB", "300 MiB", ...
std::string format_bytes(double bytes);

// Throws gipdyn::Error "WHAT needs about X but this machine has Y available; FIX"
// when `bytes` exceeds what is available.
void require_memory(double bytes, const std::string& what, const std::string& fix);

}  // namespace gipdyn
