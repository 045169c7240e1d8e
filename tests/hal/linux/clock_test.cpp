#include <cmath>

#include "gyrotc/hal/linux/monotonic_clock.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

TEST_CASE("the monotonic clock sleeps until an absolute time") {
  MonotonicClock clock;
  const double start_s = clock.now_s();
  clock.sleep_until(start_s + 0.02);
  const double slept_s = clock.now_s() - start_s;
  CHECK(slept_s >= 0.02);
  CHECK(slept_s < 1.0);
  clock.sleep_until(start_s);  // the past: returns at once
  CHECK(clock.now_s() - start_s < 1.0);
}

namespace {
struct Counter final : ClockListener {
  int calls = 0;
  double last_s = 0.0;
  void on_time_advanced(double now_s) noexcept override {
    ++calls;
    last_s = now_s;
  }
};
}  // namespace

TEST_CASE("the virtual clock moves only forward, telling its listener") {
  VirtualClock clock{1.0};
  Counter counter;
  clock.set_listener(&counter);
  CHECK(clock.now_s() == 1.0);
  clock.sleep_until(3.5);
  CHECK(clock.now_s() == 3.5);
  CHECK(counter.calls == 1);
  CHECK(counter.last_s == 3.5);
  clock.sleep_until(2.0);
  CHECK(clock.now_s() == 3.5);
  CHECK(counter.calls == 1);
}

TEST_CASE("the real-time simulation clock starts at 0 and really sleeps") {
  RealtimeSimClock clock;
  Counter counter;
  clock.set_listener(&counter);
  CHECK(clock.now_s() >= 0.0);
  CHECK(clock.now_s() < 0.5);
  clock.sleep_until(0.01);
  CHECK(clock.now_s() >= 0.01);
  CHECK(counter.calls == 1);
  CHECK(counter.last_s >= 0.01);
}
