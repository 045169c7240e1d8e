#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <string>

#include "gyrotc/app/runtime/realtime_thread.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::RealtimeOptions;
using gyrotc::app::RealtimeThread;

#if !defined(GYROTC_NO_GUEST_THREADS)  // hangs under qemu-user when SCHED_FIFO is permitted (link.cmake)
TEST_CASE("the real-time thread runs under SCHED_FIFO at the configured priority") {
  RealtimeOptions options;
  options.priority = 10;
  std::atomic<int> policy{-1};
  std::atomic<int> priority{-1};
  try {
    RealtimeThread thread(options, [&] {
      sched_param param{};
      int p = 0;
      pthread_getschedparam(pthread_self(), &p, &param);
      policy = p;
      priority = param.sched_priority;
    });
    thread.join();
    CHECK(thread.is_realtime());
  } catch (const gyrotc::app::RuntimeFailure& e) {
    WARN(std::string("skipped: SCHED_FIFO not permitted here: ") + e.what());
    return;
  }
  CHECK(policy == SCHED_FIFO);
  CHECK(priority == 10);
}
#endif

TEST_CASE("the real-time thread rejects a priority SCHED_FIFO does not have") {
  RealtimeOptions options;
  options.priority = 0;
  CHECK_THROWS_AS(RealtimeThread(options, [] {}), gyrotc::app::InputError);
}

TEST_CASE("the real-time thread rejects a CPU the process may not use") {
  RealtimeOptions options;
  options.cpu = gyrotc::app::usable_cpu_count() + 64;
  CHECK_THROWS_AS(RealtimeThread(options, [] {}), gyrotc::app::InputError);
}
