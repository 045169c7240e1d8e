#pragma once

#include <pthread.h>

#include <cstddef>
#include <functional>
#include <optional>

namespace gyrotc::app {

struct RealtimeOptions {
  int priority = 80;                     // SCHED_FIFO priority, 1..99
  std::optional<int> cpu;                // pin the real-time thread to this CPU
  bool lock_memory = true;               // mlockall before any thread starts
  std::size_t stack_bytes = 512 * 1024;  // the real-time thread's stack, prefaulted
  bool allow_non_rt = false;             // run without SCHED_FIFO / mlockall, warning
};

// mlockall(MCL_CURRENT | MCL_FUTURE): no page fault may stall the loop later.
// Call before any thread starts. Without the permission it throws
// RuntimeFailure saying what is missing, or, with allow_non_rt, logs a
// warning and returns false.
bool lock_process_memory(const RealtimeOptions& options);

// A thread running body() under SCHED_FIFO at options.priority (optionally
// pinned to one CPU), with its stack touched before body() starts so the loop
// never faults a stack page in. Without the permission for SCHED_FIFO the
// constructor throws RuntimeFailure with what to do, or, with allow_non_rt,
// runs body() under the normal scheduler and logs a warning. The destructor
// joins.
class RealtimeThread {
 public:
  RealtimeThread(const RealtimeOptions& options, std::function<void()> body);
  ~RealtimeThread();
  RealtimeThread(const RealtimeThread&) = delete;
  RealtimeThread& operator=(const RealtimeThread&) = delete;

  void join() noexcept;
  // Running under SCHED_FIFO (false after falling back with allow_non_rt).
  bool is_realtime() const noexcept { return realtime_; }

 private:
  static void* trampoline(void* self) noexcept;

  std::function<void()> body_;
  pthread_t thread_{};
  bool joinable_ = false;
  bool realtime_ = false;
};

// How many CPUs this process may run on (for messages).
int usable_cpu_count() noexcept;

}  // namespace gyrotc::app
