// Progress reporting and cancellation for long operations (tabulating tables, tracing
// captures): callers pass a TaskControl; operations report progress and stop when asked.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <stdexcept>

namespace basis {

// Thrown by an operation that stopped because its TaskControl asked it to.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("interrupted") {}
};

struct TaskControl {
  // Called with (work done, total work) from the calling thread or any worker; may be empty.
  std::function<void(std::size_t done, std::size_t total)> progress;
  // When set and true, the operation stops at its next check and throws Cancelled.
  const std::atomic<bool>* cancel = nullptr;

  void check() const {
    if (cancel && cancel->load(std::memory_order_relaxed)) throw Cancelled();
  }
  void report(std::size_t done, std::size_t total) const {
    if (progress) progress(done, total);
  }
};

}  // namespace basis
