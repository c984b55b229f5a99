#pragma once
// ThreadPool: a fixed set of worker threads that run the tasks of one parallel loop at a time,
// for stepping chunks of a batch. The threads are made once and sleep between loops, so a step
// pays a wake-up, not a thread start, and allocates nothing.
//
//   ThreadPool pool(2);                                  // the caller + 1 worker
//   pool.run(num_chunks, [&](int chunk) { step_chunk(chunk); });
//
// Tasks are handed out through one atomic counter (whoever is free takes the next), so which
// thread runs a task varies from run to run. Results do not: the batch's tasks touch disjoint
// lanes and each lane's arithmetic is the same on any thread (docs/batch.md, "Determinism").
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
    run_erased(num_tasks, &task, [](void* t, int i) { (*static_cast<Task*>(t))(i); });
  }

 private:
  using Trampoline = void (*)(void*, int);
  void run_erased(int num_tasks, void* task, Trampoline call);
  void work_on_current_loop();
  void worker_main();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  // The current loop; written under mutex_ before a generation starts.
  void* task_ = nullptr;
  Trampoline call_ = nullptr;
  int num_tasks_ = 0;
  std::uint64_t generation_ = 0;
  bool stopping_ = false;
  std::atomic<int> next_task_{0};
  int workers_busy_ = 0;
  std::exception_ptr first_error_;
  SingleThreadGuard guard_;
};

}  // namespace dronetwin
