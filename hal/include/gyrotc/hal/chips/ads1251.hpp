#pragma once

#include <cstdint>
#include <limits>

#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/devices.hpp"
#include "gyrotc/hal/gpio_line.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// ADS1251 24-bit delta-sigma ADC: conversions at fCLK/384; the combined
// DOUT/DRDY line falls when a conversion is ready, and the 24 bits must be
// clocked out (SPI mode 0, MSB first) inside the DOUT window of about
// 348/fCLK, or the data of two conversions mix. Full scale is +/- Vref.
// The same pin carries the data, so every read makes more falling edges on
// the DRDY line (the MSB, the data bits): see Ads1251::read below.
struct Ads1251Config {
  double fclk_hz = 384'000.0;          // 1 kSPS: DOUT mode ends 937.5 us after the DRDY edge
  double vref_v = 2.5;
  std::uint32_t spi_speed_hz = 1'000'000;
  // Worst case from the DRDY edge to the first SCLK (edge event wake-up,
  // scheduling): the configuration is refused if the window cannot hold it
  // plus the 24 clock periods.
  double latency_budget_s = 300e-6;
  // Worst case from the DRDY edge to the kernel's timestamp of it (the
  // interrupt's latency up to the handler that stamps; a thread on
  // PREEMPT_RT). The driver knows the edge only by its stamp, so it takes
  // the DOUT window to end this much before 360 tCLK after the stamp: a
  // kernel that stamps later than this lets a read past the window through.
  double stamp_latency_max_s = 30e-6;
};

class Ads1251 final : public RateAdc {
 public:
  static constexpr std::int32_t kCodeMax = 0x7FFFFF;   // +full scale
  static constexpr std::int32_t kCodeMin = -0x800000;  // -full scale
  static constexpr double kClocksPerSample = 384.0;    // datasheet: data rate = fCLK/384
  static constexpr double kDoutEndClocks = 360.0;      // t2 + t3 + DOUT mode: DOUT mode ends 360 tCLK after the edge
  // Datasheet t2 + t3: the DRDY pulse (6 tCLK low, 6 tCLK high) before DOUT
  // mode, plus t6 (30 ns) before the first SCLK.
  static constexpr double kHoldOffClocks = 12.0;
  static constexpr double kHoldOffExtraS = 30e-9;
  // The pin falls only in DOUT mode (up to 360 tCLK after the DRDY edge) and
  // at the next DRDY edge (384 tCLK): halfway between tells them apart.
  static constexpr double kNextDrdyClocks = 372.0;
  // A positive code's MSB pulls the pin low when DOUT mode starts, 12 tCLK
  // after the DRDY edge; edge stamps jitter by a few microseconds.
  static constexpr double kMsbToleranceClocks = 6.0;
  // The last DRDY stamp bounds an edge up to this many periods later; over
  // so few the two clocks (the part's crystal, CLOCK_MONOTONIC) drift by
  // nanoseconds at 100 ppm.
  static constexpr std::uint64_t kGridMemoryPeriods = 4;

  // drdy must deliver falling edges in order with CLOCK_MONOTONIC stamps
  // (GpioLine::wait_edge), on the same time base as clock.
  Ads1251(SpiBus& spi, GpioLine& drdy, Clock& clock, const Ads1251Config& config) noexcept;

  // Why `config` cannot be read reliably, or success.
  static Status validate(const Ads1251Config& config) noexcept;
  // Validates, then sets the bus to mode 0, 8-bit words, the configured speed.
  Status init() noexcept;

  static std::int32_t sign_extend_24(std::uint32_t raw) noexcept;
  double code_to_mv(std::int32_t code) const noexcept { return code * mv_per_code_; }
  double sample_period_s() const noexcept { return kClocksPerSample / config_.fclk_hz; }
  // From a DRDY edge's stamp to the end of DOUT mode, less the stamp's worst lateness.
  double dout_window_s() const noexcept { return window_s_; }
  const Ads1251Config& config() const noexcept { return config_; }

 private:
  // Takes the oldest queued falling edge that is a new conversion's DRDY
  // (every stamp may be up to stamp_latency_max_s late):
  //  - an edge less than half a period after the last DRDY edge is that
  //    conversion's MSB or our read's data, skipped; any other one there is
  //    counted as spurious (the part makes none: noise on the line);
  //  - an edge that may have fallen before the end of the last transfer (its
  //    stamp no more than stamp_latency_max_s after it) is that read's data,
  //    skipped, or, from 372 tCLK after the last DRDY edge on, the next DRDY
  //    edge falling while a late read still clocked: that conversion's shift
  //    pointer was moved, so it is skipped (missed). A data bit stamped
  //    within 2 x stamp_latency_max_s of where the next DRDY may fall cannot
  //    be told from it: taken for it, that conversion is skipped and its MSB
  //    counted spurious (never a sample: only a conversion lost);
  //  - a gap of n periods since the last DRDY edge: n - 1 conversions missed
  //    (counted from the first sample read on: edges queued since the line
  //    was requested are stale, not missed).
  // Then waits out the hold-off (DOUT mode starts 12 tCLK after the edge),
  // skips the conversion (missed) if 24 bits can no longer end inside the
  // window, and reads. A transfer that ended after the window is a late
  // read: its sample is dropped (and the queue kept, see do_read); one that
  // ended inside it drops the edges queued meanwhile. The window is
  // taken to end stamp_latency_max_s before the datasheet's end of DOUT mode
  // (360 tCLK) counted from the stamp: the stamp is that late at worst; or
  // from the last DRDY stamp plus the periods since, if that is earlier (the
  // conversions keep the crystal's grid), so that one stamp later than
  // stamp_latency_max_s cannot let a read past the window through.
  // Repeats until a sample is read whole or timeout_s has passed.
  Result<AdcSample> do_read(double timeout_s) noexcept override;
  AdcReadStats do_stats() const noexcept override { return stats_; }

  SpiBus& spi_;
  GpioLine& drdy_;
  Clock& clock_;
  Ads1251Config config_;
  double mv_per_code_;
  double period_s_;
  double window_s_;
  double hold_off_s_;
  double next_drdy_after_s_;
  double msb_tolerance_s_;
  double transfer_s_;
  AdcReadStats stats_;
  bool have_edge_ = false;
  bool have_read_ = false;
  double last_edge_s_ = 0.0;           // the last DRDY edge taken (read, late or skipped)
  double last_transfer_end_s_ = -std::numeric_limits<double>::infinity();
};

}  // namespace gyrotc::hal
