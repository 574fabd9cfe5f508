#pragma once
// Fork-join over independent tasks: how the library trains GP joints and
// LIP's starts, and builds and contracts large kernel matrices, on several
// cores. Each task writes only its own outputs, so results do not depend on
// the number of threads.
#include <cstddef>
#include <functional>
#include <vector>

namespace gipdyn {

// Threads for `tasks` tasks: `requested` (0: one per core), at most `tasks`,
// and no more than the memory available, less `reserved_bytes`, holds at
// `bytes_per_task` each (0: no limit); at least 1.
int worker_threads(int requested, int tasks, double bytes_per_task = 0.0, double reserved_bytes = 0.0);

// The threads to ask worker_threads for, for `tasks` independent tasks that
// share the cores: `requested`, or one per task for 0. More tasks than cores
// then end together, instead of the last one running alone while other cores
// wait; each task's result does not depend on it.
int sharing_threads(int requested, int tasks);

// Runs task(0), ..., task(tasks - 1) on `threads` threads, the caller's among
// them, each taking the next task when it finishes one, with subnormals
// flushed to zero (floating_point.hpp). The first exception a task throws is
// rethrown here once every thread has stopped; tasks not yet begun then do not run.
void run_tasks(int tasks, int threads, const std::function<void(int)>& task);

// The bounds of the ranges of `per_range` items (the last one shorter) that
// cover [0, count): range t is [bounds[t], bounds[t + 1]). One range when
// per_range >= count, or count is 0.
std::vector<std::ptrdiff_t> equal_ranges(std::ptrdiff_t count, std::ptrdiff_t per_range);

// Runs body(t, bounds[t], bounds[t + 1]) for every range of `bounds`, one task
// each: on every core when there are several ranges, on the caller's thread
// when there is one. Bounds that depend on the data alone, with a result kept
// per range and combined in range order, give the same bits on any core count.
void run_range_tasks(const std::vector<std::ptrdiff_t>& bounds,
                     const std::function<void(int, std::ptrdiff_t, std::ptrdiff_t)>& body);

}  // namespace gipdyn
