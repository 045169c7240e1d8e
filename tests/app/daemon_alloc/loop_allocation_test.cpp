// The real-time loop body allocates nothing: this test area replaces the
// global operator new with one that counts while a flag is set (its own
// executable, so no other test runs with the replacement).
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <new>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/model/plant_housing.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

void* counted_alloc(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  void* p = std::malloc(size == 0 ? 1 : size);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t size) { return counted_alloc(size); }
void* operator new[](std::size_t size) { return counted_alloc(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(size);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

using namespace gyrotc;

namespace {

// The loop body (RealtimeRunner::step) driven on the lockstep simulated
// board for 12 s: the same code the SCHED_FIFO thread runs, without the
// threads. Checks what ran and returns the allocations after the first second.
long loop_allocations(const app::DaemonConfig& config) {
  app::BoardInstance instance = app::make_board(config.board, app::SimTiming::lockstep);
  const hal::Board board = instance.board();
  const fit::Compensator compensator{fit::BiasModel::paper_reference()};
  app::Controller controller(config.controller, compensator);
  app::RealtimeRunnerOptions options;
  options.sample_period_s = hal::Ads1251::kClocksPerSample / config.board.devices.adc.fclk_hz;
  options.output_period_s = 0.1;
  app::RealtimeRunner runner(board, controller, options);
  std::size_t rows = 0;
  runner.add_row_sink([&rows](const app::OutputRow&) { ++rows; });
  runner.prime();

  const int per_second = static_cast<int>(std::lround(1.0 / options.sample_period_s));
  long during_loop = 0;
  for (int second = 0; second < 12; ++second) {
    // The sensor thread's part (allocations allowed there).
    const hal::TemperatureReading casing = board.casing_sensor.read();
    const hal::TemperatureReading ambient = board.ambient_sensor->read();
    runner.publish_readings(casing, ambient);
    g_allocations = 0;
    g_counting = true;
    for (int i = 0; i < per_second; ++i) REQUIRE(runner.step());
    g_counting = false;
    if (second >= 1) during_loop += g_allocations.load();  // the first second warms the caches up
    runner.drain();  // the output thread's part
  }
  const app::LoopCounters c = runner.counters();
  CHECK(c.samples == static_cast<std::uint64_t>(12 * per_second));
  CHECK(c.pid_ticks >= 5);
  CHECK(c.readings == 12);
  CHECK(rows >= 100);
  CHECK(controller.last_command().enable);  // the TEC loop was driving: its path ran
  return during_loop;
}

}  // namespace

TEST_CASE("the real-time loop body allocates nothing: samples, readings, PID ticks and output rows") {
  CHECK(loop_allocations(app::load_daemon_config(gyrotc::test::config_file("gyrotc-sim.toml"))) == 0);
}

TEST_CASE("the real-time loop body allocates nothing with the model-based loop in the PID's place") {
  app::DaemonConfig config = app::load_daemon_config(gyrotc::test::config_file("gyrotc-sim.toml"));
  control::ObserverLoopSpec spec;
  spec.setpoint_c = config.controller.setpoint_c;
  config.controller.observer = std::make_shared<const control::ObserverLoopDesign>(
      control::design_observer_loop(model::housing_model(model::PlantParams{}), spec));
  config.controller.pid.period_s = spec.period_s;
  CHECK(loop_allocations(config) == 0);
}

TEST_CASE("the allocation counter sees an allocation (the test can fail)") {
  g_allocations = 0;
  g_counting = true;
  void* p = ::operator new(16);  // a direct call: never elided like a new-expression may be
  g_counting = false;
  ::operator delete(p);
  CHECK(g_allocations.load() == 1);
}
