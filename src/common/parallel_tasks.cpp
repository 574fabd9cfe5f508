#include "gipdyn/parallel_tasks.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "gipdyn/floating_point.hpp"
#include "gipdyn/memory.hpp"

namespace gipdyn {

int worker_threads(int requested, int tasks, double bytes_per_task, double reserved_bytes) {
  int threads = requested > 0 ? requested : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::clamp(threads, 1, std::max(tasks, 1));
  if (bytes_per_task > 0.0)
    threads = std::min<int>(
        threads, static_cast<int>(std::max(1.0, (static_cast<double>(available_memory_bytes()) - reserved_bytes) /
                                                    bytes_per_task)));
  return threads;
}

int sharing_threads(int requested, int tasks) { return requested > 0 ? requested : tasks; }

void run_tasks(int tasks, int threads, const std::function<void(int)>& task) {
  std::atomic<int> next{0};
  std::mutex failure_mutex;
  std::exception_ptr failure;
  auto worker = [&] {
    const FlushSubnormalsToZero fast_floats;
    try {
      for (int t = next++; t < tasks; t = next++) task(t);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = tasks;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

std::vector<std::ptrdiff_t> equal_ranges(std::ptrdiff_t count, std::ptrdiff_t per_range) {
  count = std::max<std::ptrdiff_t>(count, 0);
  per_range = std::max<std::ptrdiff_t>(per_range, 1);
  std::vector<std::ptrdiff_t> bounds{0};
  for (std::ptrdiff_t end = per_range; end < count; end += per_range) bounds.push_back(end);
  bounds.push_back(count);
  return bounds;
}

void run_range_tasks(const std::vector<std::ptrdiff_t>& bounds,
                     const std::function<void(int, std::ptrdiff_t, std::ptrdiff_t)>& body) {
  const int ranges = static_cast<int>(bounds.size()) - 1;
  if (ranges < 1) return;
  run_tasks(ranges, ranges > 1 ? worker_threads(0, ranges) : 1, [&](int t) {
    body(t, bounds[static_cast<size_t>(t)], bounds[static_cast<size_t>(t) + 1]);
  });
}

}  // namespace gipdyn
