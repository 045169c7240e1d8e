#include "gyrotc/app/runtime/realtime_runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "gyrotc/app/support/log.hpp"

namespace gyrotc::app {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

RealtimeRunner::RealtimeRunner(hal::Board board, Controller& controller, const RealtimeRunnerOptions& options)
    : board_(board),
      controller_(controller),
      options_(options),
      adc_timeout_s_(options.adc_timeout_periods * options.sample_period_s),
      mid_v_(0.5 * controller.config().rate_dac_vref_v),
      ambient_c_(kNaN) {}

RealtimeRunner::~RealtimeRunner() { stop(); }

void RealtimeRunner::prime() noexcept {
  start_s_ = board_.clock.now_s();
  end_s_ = options_.duration_s > 0.0 ? start_s_ + options_.duration_s : std::numeric_limits<double>::infinity();
  next_pid_s_ = start_s_ + controller_.config().pid.period_s;
  next_row_s_ = start_s_ + options_.output_period_s;
  publish_status();
}

void RealtimeRunner::start() {
  // Safe state first: the DAC may power up anywhere and the OPA548 enabled.
  (void)board_.tec.safe_off();
  (void)board_.rate_dac.write_v(mid_v_);
  // mlockall before any thread starts, so every stack is locked too.
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer maps terabytes of shadow memory: mlockall would try to
  // lock it all. Sanitizer builds are for tests, not for the board.
  if (options_.realtime.lock_memory) GYROTC_LOG_WARNING("sanitizer build: memory not locked (mlockall skipped)");
#else
  if (options_.realtime.lock_memory) memory_locked_ = lock_process_memory(options_.realtime);
#endif
  prime();
  started_ = true;
  sensor_thread_ = std::thread([this] { sensor_loop(); });
  output_thread_ = std::thread([this] { output_loop(); });
  try {
    loop_thread_ = std::make_unique<RealtimeThread>(options_.realtime, [this] { loop(); });
  } catch (...) {
    stop();
    throw;
  }
  realtime_ = loop_thread_->is_realtime();
}

void RealtimeRunner::loop() noexcept {
  while (step()) {
  }
  finished_.store(true, std::memory_order_release);
}

bool RealtimeRunner::step() noexcept {
  const double asked_s = board_.clock.now_s();
  auto sample = board_.adc.read(adc_timeout_s_);
  // A read that fails at once (a GPIO or SPI error with no DRDY wait) must
  // not spin this SCHED_FIFO thread: the pass waits out a sample period, so
  // the loop still wakes for the TEC's period and the other threads run.
  if (!sample.ok() && board_.clock.now_s() < asked_s + options_.sample_period_s) {
    board_.clock.sleep_until(asked_s + options_.sample_period_s);
  }
  // The loop runs now: the wake-up latency is measured from the DRDY edge
  // (or the conversion instant on the simulated board).
  double now = board_.clock.now_s();
  if (sample.ok()) {
    latency_.add(now - sample->time_s);
    (void)run_sample_tick(controller_, board_.rate_dac, *sample, now, row_sums_);
    samples_.store(samples_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  } else {
    run_adc_timeout_tick(controller_, board_.rate_dac, now, row_sums_);
    adc_timeouts_.store(adc_timeouts_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  const hal::AdcReadStats adc = board_.adc.stats();
  late_reads_.store(adc.late_reads, std::memory_order_relaxed);
  spurious_edges_.store(adc.spurious_edges, std::memory_order_relaxed);
  missed_conversions_.store(adc.missed_conversions, std::memory_order_relaxed);

  // A new reading from the sensor thread: one attempt, never spin behind it.
  Readings readings;
  std::uint64_t version = 0;
  if (readings_.try_load(readings, &version) && version != readings_version_) {
    readings_version_ = version;
    controller_.on_temperature(readings.casing, now);
    if (readings.casing.valid) have_casing_ = true;
    if (board_.ambient_sensor != nullptr) {
      controller_.on_ambient_temperature(readings.ambient, now);
      if (readings.ambient.valid) ambient_c_ = readings.ambient.temp_c;
    }
    readings_count_.store(readings_count_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    publish_status();
  }

  if (now >= next_pid_s_) {
    const TecCommand command = run_pid_tick(controller_, board_.tec, now);
    row_sums_.flags |= command.flags;
    pid_ticks_.store(pid_ticks_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    while (next_pid_s_ <= now) next_pid_s_ += controller_.config().pid.period_s;
    publish_status();
  }

  if (now >= next_row_s_) {
    run_thermal_poll(controller_, board_.tec, now);
    push_row(now);
    publish_status();
    while (next_row_s_ <= now) next_row_s_ += options_.output_period_s;
  }

  // An overrun: this pass ended after the next conversion was due.
  if (sample.ok() && board_.clock.now_s() > sample->time_s + options_.sample_period_s) {
    overruns_.store(overruns_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  heartbeat_.store(heartbeat_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  now = board_.clock.now_s();
  return now < end_s_ && !stop_.load(std::memory_order_relaxed);
}

void RealtimeRunner::push_row(double now_s) noexcept {
  OutputRow row;
  row.time_s = now_s - start_s_;
  row.gyro_mv = row_sums_.mean_gyro_mv();
  row.rate_dps = row_sums_.mean_rate_dps();
  row.casing_c = have_casing_ ? controller_.last_casing_c() : kNaN;  // no reading yet: not 0 C
  row.ambient_c = ambient_c_;
  row.tec_a = controller_.reported_tec_a();
  row.setpoint_c = controller_.active_setpoint_c();
  row.flags = row_sums_.flags | controller_.flags();
  row.samples = static_cast<std::uint32_t>(row_sums_.gyro_count);
  row.have_casing = have_casing_;
  (void)ring_.try_push(row);  // full: dropped and counted by the ring
  row_sums_ = RowAccumulator{};
}

void RealtimeRunner::publish_status() noexcept {
  status_.store(LoopStatus{.casing_c = have_casing_ ? controller_.last_casing_c() : kNaN,
                           .ambient_c = ambient_c_,
                           .setpoint_c = controller_.active_setpoint_c(),
                           .tec_a = controller_.reported_tec_a(),
                           .flags = controller_.flags(),
                           .compensation_c = controller_.compensation_c(),
                           .estimate = controller_.loop_estimate()});
}

void RealtimeRunner::publish_readings(const hal::TemperatureReading& casing,
                                      const hal::TemperatureReading& ambient) noexcept {
  readings_.store(Readings{casing, ambient});
}

void RealtimeRunner::sensor_loop() {
  using clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(options_.sensor_period_s));
  auto next = clock::now();
  hal::TemperatureReading ambient;
  for (std::uint64_t cycle = 0; !threads_stop_.load(std::memory_order_relaxed); ++cycle) {
    // The schedule of ambient_conversion_due (the lockstep runner keeps it too).
    if (board_.ambient_sensor != nullptr && ambient_conversion_due(cycle)) ambient = board_.ambient_sensor->read();
    const hal::TemperatureReading casing = board_.casing_sensor.read();  // blocks for the conversion
    publish_readings(casing, ambient);
    // A cycle that overran its period (the ambient conversion, a slow bus)
    // restarts the schedule from now rather than catching up in a burst.
    next = std::max(next + period, clock::now());
    // Sleep in short slices so a stop is seen promptly.
    while (!threads_stop_.load(std::memory_order_relaxed) && clock::now() < next) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
}

std::size_t RealtimeRunner::drain() {
  std::size_t n = 0;
  OutputRow row;
  while (ring_.try_pop(row)) {
    for (const auto& sink : sinks_) sink(row);
    ++n;
  }
  return n;
}

void RealtimeRunner::output_loop() {
  while (!threads_stop_.load(std::memory_order_relaxed)) {
    drain();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

void RealtimeRunner::stop() noexcept {
  if (stopped_) return;
  stopped_ = true;
  request_stop();
  if (loop_thread_) loop_thread_->join();
  finished_.store(true, std::memory_order_release);
  // The loop thread has ended: this thread may touch the board now, and does
  // before waiting for a sensor thread that may sit in a 750 ms conversion.
  (void)board_.tec.safe_off();
  (void)board_.rate_dac.write_v(mid_v_);
  threads_stop_.store(true, std::memory_order_relaxed);
  if (sensor_thread_.joinable()) sensor_thread_.join();
  if (output_thread_.joinable()) output_thread_.join();
  try {
    if (started_) drain();
  } catch (...) {  // a sink failed while draining: the board is safe already
  }
}

LoopCounters RealtimeRunner::counters() const noexcept {
  LoopCounters c;
  c.samples = samples_.load(std::memory_order_relaxed);
  c.overruns = overruns_.load(std::memory_order_relaxed);
  c.adc_timeouts = adc_timeouts_.load(std::memory_order_relaxed);
  c.late_reads = late_reads_.load(std::memory_order_relaxed);
  c.spurious_edges = spurious_edges_.load(std::memory_order_relaxed);
  c.missed_conversions = missed_conversions_.load(std::memory_order_relaxed);
  c.missed_drdy = c.missed_conversions + c.adc_timeouts;
  c.pid_ticks = pid_ticks_.load(std::memory_order_relaxed);
  c.readings = readings_count_.load(std::memory_order_relaxed);
  c.rows_dropped = ring_.dropped();
  return c;
}

}  // namespace gyrotc::app
