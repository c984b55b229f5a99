// ThreadPool: every task runs exactly once on any number of threads, errors come back to the
// caller, and two threads sharing one pool are told so.

#include "dronetwin/batch/thread_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

namespace dronetwin {
namespace {

TEST(ThreadPool, EveryTaskRunsExactlyOnceOnAnyNumberOfThreads) {
  for (int threads : {1, 2, 3, 8}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.num_threads(), threads);
    for (int tasks : {0, 1, 2, 7, 1000}) {
      std::vector<std::atomic<int>> runs(static_cast<std::size_t>(tasks));
      for (int repeat = 0; repeat < 20; ++repeat)
        pool.run(tasks, [&](int i) { runs[static_cast<std::size_t>(i)].fetch_add(1); });
      for (int i = 0; i < tasks; ++i)
        ASSERT_EQ(runs[static_cast<std::size_t>(i)].load(), 20)
            << threads << " threads, task " << i;
    }
  }
}

// A task passed by name (an lvalue, const or not) runs as a temporary does: run() takes the
// task by forwarding reference, and Task is then a reference type.
TEST(ThreadPool, ANamedOrConstTaskRunsLikeATemporary) {
  ThreadPool pool(2);
  std::vector<std::atomic<int>> runs(64);
  auto task = [&](int i) { runs[static_cast<std::size_t>(i)].fetch_add(1); };
  const auto& const_task = task;
  pool.run(64, task);
  pool.run(64, const_task);
  for (std::size_t i = 0; i < runs.size(); ++i) ASSERT_EQ(runs[i].load(), 2) << "task " << i;
}

// How many tasks ran at once at most: each task is inside for `duration`.
class Concurrency {
 public:
  void task(std::chrono::microseconds duration) {
    const int now = inside_.fetch_add(1) + 1;
    int seen = most_.load();
    while (now > seen && !most_.compare_exchange_weak(seen, now)) {
    }
    std::this_thread::sleep_for(duration);
    inside_.fetch_sub(1);
    count_.fetch_add(1);
  }
  int most() const { return most_.load(); }
  int count() const { return count_.load(); }

 private:
  std::atomic<int> inside_{0}, most_{0}, count_{0};
};

TEST(ThreadPool, UsesMoreThanOneThreadWhenItHasThem) {
  ThreadPool pool(2);
  Concurrency c;
  pool.run(64, [&](int) { c.task(std::chrono::milliseconds(1)); });
  EXPECT_EQ(c.most(), 2);
}

// A worker out of work polls for a while, then sleeps: the next loop must reach it either way,
// and a pool must shut down from either state.
TEST(ThreadPool, TheNextLoopReachesAWorkerThatPolledOrSlept) {
  for (const auto pause : {std::chrono::microseconds(0), std::chrono::microseconds(20),
                           std::chrono::microseconds(5000)}) {
    ThreadPool pool(2);
    for (int repeat = 0; repeat < 5; ++repeat) {
      std::this_thread::sleep_for(pause);
      Concurrency c;
      // Tasks long enough that the worker, however late it wakes, finds some left.
      pool.run(16, [&](int) { c.task(std::chrono::milliseconds(2)); });
      EXPECT_EQ(c.count(), 16) << "pause " << pause.count() << " us";
      EXPECT_EQ(c.most(), 2) << "pause " << pause.count() << " us";
    }
  }
}

// Many short loops, the worker sometimes late: every task has finished when run() returns, and
// its writes (plain ints, no atomics) are visible to the caller (ThreadSanitizer checks the
// ordering in the tsan preset).
TEST(ThreadPool, EveryTaskHasFinishedWhenRunReturns) {
  ThreadPool pool(2);
  std::vector<int> hits(3, 0);
  for (int repeat = 1; repeat <= 20000; ++repeat) {
    pool.run(3, [&](int i) { ++hits[static_cast<std::size_t>(i)]; });
    for (int i = 0; i < 3; ++i) ASSERT_EQ(hits[static_cast<std::size_t>(i)], repeat) << i;
    if (repeat % 1000 == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

TEST(ThreadPool, ATaskErrorReachesTheCallerAndThePoolStaysUsable) {
  ThreadPool pool(2);
  EXPECT_THROW(pool.run(50,
                        [](int i) {
                          if (i == 17) throw std::runtime_error("task 17 failed");
                        }),
               std::runtime_error);
  std::atomic<int> count{0};
  pool.run(10, [&](int) { count.fetch_add(1); });
  EXPECT_EQ(count.load(), 10);
}

TEST(ThreadPool, TwoCallersOfOnePoolAreRefused) {
  ThreadPool pool(2);
  std::atomic<bool> started{false}, release{false};
  std::thread first([&] {
    pool.run(2, [&](int) {
      started = true;
      while (!release) std::this_thread::yield();
    });
  });
  while (!started) std::this_thread::yield();
  EXPECT_THROW(pool.run(1, [](int) {}), SimulationError);
  release = true;
  first.join();
}

TEST(ThreadPool, BadSizesAreNamed) {
  EXPECT_THROW(ThreadPool(0), InvalidArgument);
  EXPECT_THROW(ThreadPool(-3), InvalidArgument);
}

}  // namespace
}  // namespace dronetwin
