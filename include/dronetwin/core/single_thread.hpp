#pragma once
// SingleThreadGuard: an object that may be used from only one thread at a time says so, instead
// of corrupting itself. A Simulator stepped from two Python threads (step(n) releases the GIL) or
// reset() while another thread runs its ClosedLoop would otherwise lose steps or mix states.
//
//   class Simulator {
//     SingleThreadGuard guard_;
//     StepResult step(std::int64_t n) {
//       const SingleThreadGuard::Hold hold(guard_, "Simulator::step");   // throws when busy
//       ...
//     }
//   };
//
// A Hold is re-entrant on its own thread (step(n) may call reset-free internals that hold again),
// and free of locks: one compare-and-swap to take it, one store to give it back. check() is a
// single relaxed load, for hot paths that only need to notice another thread's Hold.
//
// Trap: this detects misuse, it does not serialise: the second thread gets a SimulationError
// (Python RuntimeError) and must not retry in a loop expecting to wait.

#include <atomic>
#include <string>
#include <thread>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

class SingleThreadGuard {
 public:
  SingleThreadGuard() = default;
  // A copy of an object is a new object: it is not in use.
  SingleThreadGuard(const SingleThreadGuard&) noexcept {}
  SingleThreadGuard& operator=(const SingleThreadGuard&) noexcept { return *this; }

  /// Takes the guard for the current thread for its lifetime.
  class Hold {
   public:
    Hold(const SingleThreadGuard& guard, const char* what) : guard_(guard) {
      const std::thread::id self = std::this_thread::get_id();
      std::thread::id expected{};
      if (guard_.owner_.compare_exchange_strong(expected, self, std::memory_order_acquire)) {
        outermost_ = true;
      } else if (expected != self) {
        throw SimulationError(std::string(what) +
                              ": this object is in use by another thread (one thread at a time: "
                              "give each thread its own copy, or wait for the other call)");
      }
    }
    ~Hold() {
      if (outermost_) guard_.owner_.store(std::thread::id{}, std::memory_order_release);
    }
    Hold(const Hold&) = delete;
    Hold& operator=(const Hold&) = delete;

   private:
    const SingleThreadGuard& guard_;
    bool outermost_ = false;
  };

  /// Throws like Hold when another thread holds the guard; free when none does.
  void check(const char* what) const {
    const std::thread::id owner = owner_.load(std::memory_order_relaxed);
    if (owner != std::thread::id{} && owner != std::this_thread::get_id()) {
      throw SimulationError(std::string(what) +
                            ": this object is in use by another thread (one thread at a time)");
    }
  }

 private:
  mutable std::atomic<std::thread::id> owner_{};
};

}  // namespace dronetwin
