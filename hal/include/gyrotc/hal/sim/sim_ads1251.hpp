#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>

#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/gpio_line.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// Bit-level ADS1251 simulator, as hostile as the chip: one DOUT/DRDY pin that
// both announces conversions and shifts the data out, read through the
// kernel's GPIO edge-event queue.
//
// The pin, per conversion k (fCLK periods T, the DRDY falling edge of
// conversion k at e_k = k * 384 T; ADS1251/ADS1253 datasheet digital timing):
//   e_k - 24T .. e_k        HIGH (t4, DRDY mode)
//   e_k       .. e_k +  6T  LOW  (t2: the DRDY pulse; the output register
//                                 holds conversion k, its shift pointer is reset)
//   e_k +  6T .. e_k + 12T  HIGH (t3)
//   e_k + 12T .. e_k + 360T DOUT mode (348 T): the bit at the shift pointer;
//                           every SCLK falling edge moves it on, and after the
//                           24th the pin stays LOW. A negative code's MSB
//                           keeps the pin HIGH, a positive one pulls it LOW:
//                           one more falling edge 12 T after the DRDY one.
// So a conversion gives a burst of falling edges (the pulse, the MSB, the
// data bits during a read), and a read that is early (inside the DRDY pulse),
// late (past the DOUT window) or repeated (the pointer is past the 24th bit:
// zeros) returns mixed, shifted or zero data, as the part does. SCLK edges
// during the pulse move the pointer of the new conversion too.
//
// The DRDY line behaves like a GPIO line requested for edge events: every
// transition the request selects is queued (at most kQueueEvents, newer ones
// dropped when full, as the v1 uAPI's kfifo does) with the time of the edge
// as its timestamp, or later by the stamping handler's latency (Timing::
// stamp_delay_max_s: a real kernel stamps in its interrupt handler, not at
// the pin); an event becomes readable irq_delay after the edge. With
// a both-edge request the v1 kernel labels each event by the line level its
// IRQ thread reads then, so a DRDY pulse already over is labelled rising.
// wait_edge() returns the oldest queued event of the wanted kind (skipping
// others), discard_edges() drops the queue, get() reads the pin.
//
// SPI modes: the part shifts DOUT on SCLK falling edges and is read in mode 0
// (sampled on the rising edge). In any other mode the sample is taken at the
// edge the part shifts on, or after it: the race between the controller's
// sample and the part's 5 ns hold time (t8) goes the part's worst way, and
// every bit read is the next one (the code comes back shifted left by one,
// its LSB the pin's level after the 24th bit). Such reads count as corrupted.
//
// Emulation (Config::pin_listener set, gyrotc-emu): the pin drives a real
// GPIO line, and the kernel queues its edges. Every level change goes to the
// listener instead of the internal queue; a DRDY edge is anchored to the time
// the pin really falls (the emulator's thread may run late: the conversion's
// window then starts from that time, as the part's own timing would, and the
// following conversions keep their period from it: the clock's phase slips,
// Counters::late_edges); transfers shift bit by bit so every data edge
// reaches the line.
//
// Time comes from the board's clock: a VirtualClock jumps (lockstep), a
// RealtimeSimClock really sleeps. The reader's environment is randomised per
// seed (Timing): wait_edge() returns wake-up latency after the event that
// woke it became readable (immediately for an event already queued), and a
// transfer clocks after the SPI driver's start time and returns after its
// 24 SCLKs plus the driver's return time. The
// per-sample path allocates nothing and takes no lock.
class SimAds1251 {
 public:
  // The analog input: the gyro voltage of the conversion ending at t_s.
  class Input {
   public:
    virtual ~Input() = default;
    virtual double input_mv(double t_s) noexcept = 0;
  };

  // The pin's level changes, for an emulator that drives a real GPIO line.
  // Called on the thread that moved the pin, with the time of the change.
  class PinListener {
   public:
    virtual ~PinListener() = default;
    virtual void on_pin_level(bool high, double t_s) noexcept = 0;
  };

  // Which edges the simulated GPIO request queues.
  enum class EdgeRequest : std::uint8_t {
    falling,  // falling edges only (every event is a falling edge)
    both_v1,  // both edges, labelled by the level when the IRQ thread runs (uAPI v1)
  };

  // The reader's environment. Uniform draws from a splitmix64 stream of `seed`.
  struct Timing {
    double wake_min_s = 0.0;          // event readable -> wait_edge returns, uniform in [min, max]
    double wake_max_s = 0.0;
    double stall_probability = 0.0;   // per wake-up: a stall, uniform in [wake_max_s, stall_max_s]
    double stall_max_s = 0.0;
    double irq_delay_max_s = 0.0;     // edge -> event readable (and labelled), uniform in [0, max]
    double stamp_delay_max_s = 0.0;   // edge -> the kernel's timestamp of it (the handler that stamps
                                      // runs late too), uniform in [0, max]; never after readable
    double late_stamp_probability = 0.0;  // per edge: a stamp later than that (an interrupt held off),
    double late_stamp_max_s = 0.0;        // uniform in [stamp_delay_max_s, late_stamp_max_s]
    double spi_start_max_s = 0.0;     // transfer called -> first SCLK (SPI message queue), uniform in [0, max]
    double spi_return_max_s = 0.0;    // last SCLK -> transfer returns, uniform in [0, max]
    std::uint64_t seed = 1;
  };

  struct Config {
    double fclk_hz = 384'000.0;
    double vref_v = 2.5;
    EdgeRequest request = EdgeRequest::falling;
    Timing timing;
    PinListener* pin_listener = nullptr;  // emulation: the pin drives a real line (see above)
  };

  // Reads the simulator saw (any thread; relaxed counters).
  struct Counters {
    std::uint64_t conversions = 0;     // DRDY edges produced
    std::uint64_t reads = 0;           // SPI transfers
    std::uint64_t clean_reads = 0;     // 24 bits, all inside one DOUT window from its MSB
    std::uint64_t corrupted_reads = 0; // anything else: early, late, repeated, partial
    std::uint64_t dropped_events = 0;  // edge events lost to a full queue
    std::uint64_t late_edges = 0;      // emulation: DRDY edges written more than 6 tCLK late (the grid slips)
  };

  static constexpr std::size_t kQueueEvents = 16;  // the v1 uAPI's per-line kfifo

  SimAds1251(Input& input, Clock& clock, const Config& config) noexcept;
  SimAds1251(const SimAds1251&) = delete;
  SimAds1251& operator=(const SimAds1251&) = delete;

  SpiBus& spi() noexcept { return spi_; }
  GpioLine& drdy() noexcept { return drdy_; }

  // The code the converter produces for an input (rounded, clipped).
  std::int32_t code_for_mv(double mv) const noexcept {
    const double code = mv * codes_per_mv_;
    if (!(code < Ads1251::kCodeMax)) return code != code ? 0 : Ads1251::kCodeMax;  // NaN: 0
    if (code <= Ads1251::kCodeMin) return Ads1251::kCodeMin;
    // Round half away from zero; cheaper than nearbyint on the per-sample path.
    return static_cast<std::int32_t>(code + (code < 0.0 ? -0.5 : 0.5));
  }
  double sample_period_s() const noexcept { return period_s_; }
  // The code conversion k (DRDY edge at k * sample_period_s) produced, while
  // it is among the last kHistory conversions.
  std::optional<std::int32_t> code_of_conversion(std::int64_t k) const noexcept {
    const auto slot = static_cast<std::size_t>(k) % kHistory;
    if (k < 0 || history_index_[slot] != k) return std::nullopt;
    return history_code_[slot];
  }
  static constexpr std::size_t kHistory = 64;

  // Fault injection (any thread): DRDY never falls (the pin stays HIGH);
  // every SPI transfer fails.
  void set_drdy_stall(bool on) noexcept { stall_.store(on, std::memory_order_relaxed); }
  void set_spi_error(bool on) noexcept { spi_error_.store(on, std::memory_order_relaxed); }
  bool drdy_stalled() const noexcept { return stall_.load(std::memory_order_relaxed); }
  bool spi_failing() const noexcept { return spi_error_.load(std::memory_order_relaxed); }
  // Noise (the thread that reads): one spike low at t_s, a falling edge the
  // part itself never makes.
  void inject_glitch(double t_s) noexcept { glitch_s_ = t_s; }

  Counters counters() const noexcept;

  // Emulation: moves the pin to the clock's now (the listener hears every
  // change) and returns when it next changes by itself. The caller
  // serialises this with the SPI calls.
  double run_pin() noexcept;
  // The SPI mode the bus was last configured with (0xFF: not yet).
  std::uint8_t spi_mode() const noexcept { return spi_mode_; }
  // The last transfer: its first SCLK and the DRDY edge of the conversion
  // the pin showed then (the thread that reads).
  struct TransferTiming {
    double start_s = 0.0;
    double edge_s = 0.0;
    bool clean = false;
  };
  TransferTiming last_transfer() const noexcept { return last_transfer_; }
  double tclk_s() const noexcept { return tclk_s_; }

 private:
  class Bus final : public SpiBus {
   public:
    explicit Bus(SimAds1251& chip) noexcept : chip_(chip) {}

   private:
    Status do_configure(const SpiConfig& config) noexcept override;
    Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept override;
    std::string_view do_name() const noexcept override { return "sim:ads1251"; }
    SimAds1251& chip_;
  };
  class Drdy final : public GpioLine {
   public:
    explicit Drdy(SimAds1251& chip) noexcept : chip_(chip) {}

   private:
    Status do_set(bool high) noexcept override;
    Result<bool> do_get() noexcept override;
    Result<double> do_wait_edge(Edge edge, double timeout_s) noexcept override;
    Result<int> do_discard_edges() noexcept override;
    std::string_view do_name() const noexcept override { return "sim:ads1251-drdy"; }
    SimAds1251& chip_;
  };

  // Where the pin is within the conversion cycle of the last DRDY edge.
  enum class Segment : std::uint8_t { pulse_low, pulse_high, dout, drdy_high };

  struct Event {
    double stamp_s = 0.0;    // the edge
    double visible_s = 0.0;  // readable from the queue
    bool falling = true;     // the label (both_v1: fixed when it becomes visible)
    bool labelled = true;
  };

  // Moves the pin's state machine to t_s (never backwards), queueing the
  // edges on the way.
  void advance_to(double t_s) noexcept;
  void enter(Segment segment) noexcept;  // and the time it ends
  void cross_boundary(double t_s) noexcept;  // at t_s (the boundary, or later for an anchored DRDY edge)
  void set_level(bool level, double t_s) noexcept;
  void queue_edge(double t_s, bool falling, double irq_delay_s) noexcept;
  void label_visible(double t_s) noexcept;
  bool dout_bit() const noexcept;
  void shift(double t_s) noexcept;
  Result<double> wait(Edge edge, double timeout_s) noexcept;
  Status transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept;
  double uniform(double lo, double hi) noexcept;
  double wake_latency_s() noexcept;
  static void bump(std::atomic<std::uint64_t>& counter) noexcept {
    counter.store(counter.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }

  Input& input_;
  Clock& clock_;
  Config config_;
  double tclk_s_;
  double period_s_;
  double codes_per_mv_;
  Bus spi_{*this};
  Drdy drdy_{*this};
  std::uint8_t spi_mode_ = 0xFF;  // not configured
  double bit_s_ = 1e-6;           // one SCLK period at the configured speed

  // Pin state at t_s_.
  double t_s_ = 0.0;
  std::int64_t cycle_ = 0;        // conversion k of the last DRDY edge
  double edge_s_ = 0.0;           // its DRDY edge (k * period, or later when anchored)
  Segment segment_ = Segment::drdy_high;
  double boundary_s_ = 0.0;       // when segment_ ends
  std::uint32_t frame_ = 0;       // conversion k's 24-bit code
  int pointer_ = 0;               // SCLK falling edges since the DRDY edge
  bool level_ = true;

  std::array<Event, kQueueEvents> queue_{};
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  double last_visible_s_ = 0.0;   // the IRQ thread queues in edge order
  double glitch_s_ = std::numeric_limits<double>::infinity();

  TransferTiming last_transfer_;

  std::array<std::int32_t, kHistory> history_code_{};
  std::array<std::int64_t, kHistory> history_index_{};

  std::uint64_t rng_;
  std::atomic<bool> stall_{false};
  std::atomic<bool> spi_error_{false};
  std::atomic<std::uint64_t> conversions_{0};
  std::atomic<std::uint64_t> reads_{0};
  std::atomic<std::uint64_t> clean_reads_{0};
  std::atomic<std::uint64_t> corrupted_reads_{0};
  std::atomic<std::uint64_t> dropped_events_{0};
  std::atomic<std::uint64_t> late_edges_{0};
};

}  // namespace gyrotc::hal
