#pragma once
// ThreadPool: a fixed set of worker threads that run the tasks of one parallel loop at a time,
// for stepping chunks of a batch. The threads are made once and wait between loops, so a step
// pays a hand-over, not a thread start, and allocates nothing. A thread out of work polls for
// 50 us before it sleeps (a stepping loop usually calls again within that time, and a sleeping
// thread costs a wake-up of tens of microseconds), so an idle pool burns at most that per call.
//
//   ThreadPool pool(2);                                  // the caller + 1 worker
//   pool.run(num_chunks, [&](int chunk) { step_chunk(chunk); });
//
// Each thread owns a contiguous range of the tasks, the same from run to run, so a batch's chunk
// keeps being stepped by the same core and its lanes' data stay in that core's caches (handing
// tasks out from one shared counter moved them between cores on every call, which cost a fixed
// share of a short call: docs/performance.md). A thread that finishes its range takes what is left
// of the others', so a thread that wakes late is made up for. Which thread runs a task therefore
// still varies; results do not: the batch's tasks touch disjoint lanes and each lane's arithmetic
// is the same on any thread (docs/batch.md, "Determinism").
//
// The calling thread works too, so a pool of 1 runs everything inline with no thread at all. run()
// rethrows the first exception a task threw, once the threads have stopped (the other tasks may
// or may not have run).
// Trap: run() is not re-entrant and one pool serves one loop at a time; a second thread calling
// run() while the first is inside gets a SimulationError instead of a mixed-up loop.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

#include "dronetwin/core/single_thread.hpp"

namespace dronetwin {

class ThreadPool {
 public:
  /// `num_threads` >= 1 threads in all, counting the caller of run().
  explicit ThreadPool(int num_threads = 1);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int num_threads() const { return static_cast<int>(workers_.size()) + 1; }

  /// Calls task(i) once for every i in [0, num_tasks), spread over the threads; returns when all
  /// are done.
  template <class Task>
  void run(int num_tasks, Task&& task) {
    using Fn = std::remove_reference_t<Task>;
    run_erased(num_tasks, const_cast<void*>(static_cast<const void*>(&task)),
               [](void* t, int i) { (*static_cast<Fn*>(t))(i); });
  }

 private:
  using Trampoline = void (*)(void*, int);
  void run_erased(int num_tasks, void* task, Trampoline call);
  void work_on_current_loop(int self);
  void worker_main(int self);

  /// One thread's range of the current loop's tasks: it takes them from `next` on; others take
  /// what is left once their own range is done. A cache line each, so that taking one's own
  /// tasks does not contend with the other threads.
  struct alignas(64) Range {
    std::atomic<int> next{0};
    int end = 0;
  };

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  // The current loop; written under mutex_ before a generation starts.
  void* task_ = nullptr;
  Trampoline call_ = nullptr;
  // Written under mutex_ (so that sleepers cannot miss them), read by polling threads without it.
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> stopping_{false};
  std::vector<Range> ranges_;  ///< one per thread, the caller's first
  std::atomic<int> workers_busy_{0};
  std::exception_ptr first_error_;
  SingleThreadGuard guard_;
};

}  // namespace dronetwin
