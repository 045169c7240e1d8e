#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/runtime/latency_histogram.hpp"
#include "gyrotc/app/runtime/realtime_thread.hpp"
#include "gyrotc/app/runtime/seqlock.hpp"
#include "gyrotc/app/runtime/spsc_ring.hpp"
#include "gyrotc/hal/board.hpp"

// The real-time runner (docs/ARCHITECTURE.md, "One controller, two runners"): the
// same Controller as the lockstep runner, driven by three threads.
//
//  - The loop (SCHED_FIFO, RealtimeThread): paced by the ADC, whose read()
//    waits for the DRDY edge (LinuxBoard) or sleeps to the next conversion
//    with an absolute clock_nanosleep (the real-time SimBoard). Every sample
//    is compensated and written to the rate DAC; every PID period the OPA548
//    flag is read, Controller::on_pid_tick runs and the TEC command is
//    applied. No allocation, lock, log or blocking I/O in step().
//  - The sensor thread reads the DS18B20(s) (750 ms conversions) and hands
//    each reading to the loop through a Seqlock.
//  - The output thread drains a fixed-size SpscRing of OutputRows (means over
//    output_period_s) to the row sinks; when it falls behind, rows are
//    dropped and counted, the loop never waits.
namespace gyrotc::app {

struct RealtimeRunnerOptions {
  RealtimeOptions realtime;
  double duration_s = 0.0;         // 0: until request_stop()
  double sample_period_s = 1e-3;   // the ADC's conversion period (ADS1251: 384 / fclk)
  double output_period_s = 1.0;    // one OutputRow per period
  double sensor_period_s = 1.0;    // one DS18B20 conversion per period
  double adc_timeout_periods = 3.0;  // a DRDY wait longer than this many sample periods is a timeout
};

// Means over one output period, as the output thread sees them.
struct OutputRow {
  double time_s = 0.0;          // board time at the end of the period
  double gyro_mv = 0.0;         // raw ADC input, mean
  double rate_dps = 0.0;        // compensated rate, mean over valid samples (NaN if none)
  double casing_c = 0.0;        // last casing reading the controller accepted
  double ambient_c = 0.0;       // last ambient reading (NaN without an ambient sensor)
  double tec_a = 0.0;           // TEC current commanded (0 when off)
  double setpoint_c = 0.0;
  std::uint32_t flags = 0;      // controller flags, OR-ed over the period
  std::uint32_t samples = 0;    // ADC samples in the period
  bool have_casing = false;     // a valid casing reading has been seen
};

struct LoopCounters {
  std::uint64_t samples = 0;
  std::uint64_t overruns = 0;      // a loop pass longer than a sample period
  std::uint64_t missed_drdy = 0;   // missed_conversions plus DRDY timeouts
  std::uint64_t adc_timeouts = 0;
  // From the ADC driver (hal::AdcReadStats): conversions not delivered.
  std::uint64_t late_reads = 0;          // read past the DOUT window, dropped
  std::uint64_t spurious_edges = 0;      // DRDY line noise
  std::uint64_t missed_conversions = 0;  // never read
  std::uint64_t pid_ticks = 0;
  std::uint64_t readings = 0;      // casing readings handed to the controller
  std::uint64_t rows_dropped = 0;  // output ring full
};

// The controller's state as the loop last published it, for the status line
// (read on any thread through a Seqlock: the loop thread owns the controller).
struct LoopStatus {
  double casing_c = 0.0;     // last casing reading accepted (NaN before the first)
  double ambient_c = 0.0;    // last ambient reading (NaN without an ambient sensor or before the first)
  double setpoint_c = 0.0;   // active setpoint
  double tec_a = 0.0;        // commanded TEC current (0 when off)
  std::uint32_t flags = 0;   // controller flags
  double compensation_c = 0.0;  // the temperature the rate is compensated at (NaN before the first reading)
  LoopEstimate estimate;        // the model-based loop's
};

class RealtimeRunner {
 public:
  using RowSink = std::function<void(const OutputRow&)>;

  // Board and controller are referenced, not owned. The board's clock
  // must be the one its ADC timestamps samples with.
  RealtimeRunner(hal::Board board, Controller& controller, const RealtimeRunnerOptions& options);
  ~RealtimeRunner();
  RealtimeRunner(const RealtimeRunner&) = delete;
  RealtimeRunner& operator=(const RealtimeRunner&) = delete;

  // Called by the output thread with every row (set before start()).
  void add_row_sink(RowSink sink) { sinks_.push_back(std::move(sink)); }

  // mlockall (options.realtime.lock_memory), the TEC safe-off, then the
  // sensor, output and loop threads. Throws RuntimeFailure without the
  // SCHED_FIFO / mlockall permission unless allow_non_rt.
  void start();
  // Any thread, async-signal-safe: the loop ends after its current pass.
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  // The loop has ended (duration reached or stop requested).
  bool finished() const noexcept { return finished_.load(std::memory_order_acquire); }
  // Stops the loop, puts the board in the safe state as soon as the loop
  // thread has ended (TEC DAC 0 A, OPA548 disabled, rate DAC mid-scale: not
  // behind a DS18B20 read of up to 1.5 s), then joins the other threads and
  // drains the ring to the sinks. Idempotent; the destructor calls it.
  void stop() noexcept;

  bool is_realtime() const noexcept { return realtime_; }
  bool memory_locked() const noexcept { return memory_locked_; }
  LoopCounters counters() const noexcept;
  LoopStatus status() const noexcept { return status_.load(); }
  LatencyHistogram::Summary latency() const noexcept { return latency_.summary(); }
  // Passes of the loop so far (a watchdog pings only while this moves).
  std::uint64_t heartbeat() const noexcept { return heartbeat_.load(std::memory_order_relaxed); }

  // --- the pieces the threads run, public for tests that drive them
  //     single-threaded on a lockstep SimBoard --------------------------
  // Prepares the loop state at the board's current time.
  void prime() noexcept;
  // One pass of the loop: wait for a sample, compensate, PID when due,
  // hand a row over when due. False once the duration is reached or a stop
  // was requested. No allocation, no lock, no system call but the board's.
  bool step() noexcept;
  // The sensor thread's hand-over (one writer).
  void publish_readings(const hal::TemperatureReading& casing, const hal::TemperatureReading& ambient) noexcept;
  // The output thread's drain: every queued row to the sinks. Returns the count.
  std::size_t drain() ;

 private:
  struct Readings {
    hal::TemperatureReading casing;
    hal::TemperatureReading ambient;
  };
  static constexpr std::size_t kRingRows = 1024;

  void loop() noexcept;
  void sensor_loop();
  void output_loop();
  void push_row(double now_s) noexcept;
  void publish_status() noexcept;

  hal::Board board_;
  Controller& controller_;
  RealtimeRunnerOptions options_;
  std::vector<RowSink> sinks_;

  double sample_period_s_;
  double adc_timeout_s_;
  double mid_v_;

  // Loop state (loop thread only).
  double start_s_ = 0.0;
  double end_s_ = 0.0;
  double next_pid_s_ = 0.0;
  double next_row_s_ = 0.0;
  std::uint64_t readings_version_ = 0;
  RowAccumulator row_sums_;
  bool have_casing_ = false;
  double ambient_c_;

  // Shared.
  Seqlock<Readings> readings_;
  Seqlock<LoopStatus> status_;
  SpscRing<OutputRow, kRingRows> ring_;
  LatencyHistogram latency_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> finished_{false};
  std::atomic<bool> threads_stop_{false};
  std::atomic<std::uint64_t> heartbeat_{0};
  std::atomic<std::uint64_t> samples_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<std::uint64_t> adc_timeouts_{0};
  std::atomic<std::uint64_t> late_reads_{0};
  std::atomic<std::uint64_t> spurious_edges_{0};
  std::atomic<std::uint64_t> missed_conversions_{0};
  std::atomic<std::uint64_t> pid_ticks_{0};
  std::atomic<std::uint64_t> readings_count_{0};

  bool started_ = false;
  bool stopped_ = false;
  bool realtime_ = false;
  bool memory_locked_ = false;
  std::thread sensor_thread_;
  std::thread output_thread_;
  std::unique_ptr<RealtimeThread> loop_thread_;
};

}  // namespace gyrotc::app
