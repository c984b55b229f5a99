#include "dronetwin/batch/thread_pool.hpp"

#include <chrono>
#include <utility>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

// How long a thread that has run out of work keeps polling before it sleeps on the condition
// variable. A futex wake-up costs tens of microseconds on a virtual machine, a fixed share of
// every call that was most of what kept two threads from twice the speed of one
// (docs/performance.md); a stepping loop calls again within microseconds, so a short poll catches
// the next call (the worker) or the other thread's last task (the caller) without sleeping.
constexpr auto kPollBeforeSleep = std::chrono::microseconds(50);

// Polls `ready` until it holds or kPollBeforeSleep has passed; says whether it held.
template <class Ready>
bool poll_for(Ready ready) {
  const auto until = std::chrono::steady_clock::now() + kPollBeforeSleep;
  for (;;) {
    for (int i = 0; i < 64; ++i) {
      if (ready()) return true;
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
    }
    if (std::chrono::steady_clock::now() >= until) return false;
  }
}

}  // namespace

ThreadPool::ThreadPool(int num_threads) {
  require(num_threads >= 1 && num_threads <= 1024,
          "ThreadPool: num_threads: expected 1 to 1024 threads, got ", num_threads);
  ranges_ = std::vector<Range>(static_cast<std::size_t>(num_threads));
  workers_.reserve(static_cast<std::size_t>(num_threads - 1));
  for (int i = 1; i < num_threads; ++i) workers_.emplace_back([this, i] { worker_main(i); });
}

ThreadPool::~ThreadPool() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_.store(true, std::memory_order_release);
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void ThreadPool::work_on_current_loop(int self) {
  // Its own range first, then the others' leftovers, starting with the next thread's.
  const int n = static_cast<int>(ranges_.size());
  for (int k = 0; k < n; ++k) {
    Range& range = ranges_[static_cast<std::size_t>((self + k) % n)];
    for (;;) {
      const int i = range.next.fetch_add(1, std::memory_order_relaxed);
      if (i >= range.end) break;
      try {
        call_(task_, i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mutex_);
        if (!first_error_) first_error_ = std::current_exception();
      }
    }
  }
}

void ThreadPool::worker_main(int self) {
  std::uint64_t seen = 0;
  const auto ready = [&] {
    return stopping_.load(std::memory_order_acquire) ||
           generation_.load(std::memory_order_acquire) != seen;
  };
  for (;;) {
    if (!poll_for(ready)) {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, ready);
    }
    if (stopping_.load(std::memory_order_acquire)) return;
    seen = generation_.load(std::memory_order_acquire);
    work_on_current_loop(self);
    if (workers_busy_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      // Taking the mutex orders this against the caller's check-then-sleep in done_.wait, so the
      // notification cannot fall between the two.
      { const std::lock_guard<std::mutex> lock(mutex_); }
      done_.notify_one();
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
    // Contiguous, as equal as can be: thread t gets [t N / T, (t + 1) N / T).
    const auto threads = static_cast<std::int64_t>(ranges_.size());
    for (std::int64_t t = 0; t < threads; ++t) {
      Range& range = ranges_[static_cast<std::size_t>(t)];
      range.next.store(static_cast<int>(t * num_tasks / threads), std::memory_order_relaxed);
      range.end = static_cast<int>((t + 1) * num_tasks / threads);
    }
    workers_busy_.store(static_cast<int>(workers_.size()), std::memory_order_relaxed);
    // Release: a worker that sees the new generation sees the loop written above.
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
  work_on_current_loop(0);
  const auto all_done = [&] { return workers_busy_.load(std::memory_order_acquire) == 0; };
  if (!poll_for(all_done)) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, all_done);
  }
  if (first_error_) std::rethrow_exception(std::exchange(first_error_, nullptr));
}

}  // namespace dronetwin
