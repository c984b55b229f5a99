#include "dronetwin/batch/thread_pool.hpp"

#include <utility>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

ThreadPool::ThreadPool(int num_threads) {
  require(num_threads >= 1 && num_threads <= 1024,
          "ThreadPool: num_threads: expected 1 to 1024 threads, got ", num_threads);
  workers_.reserve(static_cast<std::size_t>(num_threads - 1));
  for (int i = 1; i < num_threads; ++i) workers_.emplace_back([this] { worker_main(); });
}

ThreadPool::~ThreadPool() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void ThreadPool::work_on_current_loop() {
  for (;;) {
    const int i = next_task_.fetch_add(1, std::memory_order_relaxed);
    if (i >= num_tasks_) return;
    try {
      call_(task_, i);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (!first_error_) first_error_ = std::current_exception();
    }
  }
}

void ThreadPool::worker_main() {
  std::uint64_t seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation_;
    }
    work_on_current_loop();
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (--workers_busy_ == 0) done_.notify_one();
    }
  }
}

void ThreadPool::run_erased(int num_tasks, void* task, Trampoline call) {
  const SingleThreadGuard::Hold hold(guard_, "ThreadPool::run");
  if (num_tasks <= 0) return;
  first_error_ = nullptr;
  if (workers_.empty() || num_tasks == 1) {
    for (int i = 0; i < num_tasks; ++i) call(task, i);
    return;
  }
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    task_ = task;
    call_ = call;
    num_tasks_ = num_tasks;
    next_task_.store(0, std::memory_order_relaxed);
    workers_busy_ = static_cast<int>(workers_.size());
    ++generation_;
  }
  wake_.notify_all();
  work_on_current_loop();
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [&] { return workers_busy_ == 0; });
  if (first_error_) std::rethrow_exception(std::exchange(first_error_, nullptr));
}

}  // namespace dronetwin
