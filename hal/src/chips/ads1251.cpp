#include "gyrotc/hal/chips/ads1251.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace gyrotc::hal {

Ads1251::Ads1251(SpiBus& spi, GpioLine& drdy, Clock& clock, const Ads1251Config& config) noexcept
    : spi_(spi),
      drdy_(drdy),
      clock_(clock),
      config_(config),
      mv_per_code_(config.vref_v * 1000.0 / 8388608.0),
      period_s_(kClocksPerSample / config.fclk_hz),
      window_s_(kDoutEndClocks / config.fclk_hz - config.stamp_latency_max_s),
      hold_off_s_(kHoldOffClocks / config.fclk_hz + kHoldOffExtraS),
      next_drdy_after_s_(kNextDrdyClocks / config.fclk_hz),
      msb_tolerance_s_(kMsbToleranceClocks / config.fclk_hz + config.stamp_latency_max_s),
      transfer_s_(24.0 / config.spi_speed_hz) {}

Status Ads1251::validate(const Ads1251Config& config) noexcept {
  if (!(config.fclk_hz > 0.0) || !(config.vref_v > 0.0) || config.spi_speed_hz == 0 ||
      !(config.latency_budget_s >= 0.0) || !(config.stamp_latency_max_s >= 0.0)) {
    return Error::make(ErrorCode::invalid_config,
                       "ADS1251: fclk_hz, vref_v, spi_speed_hz must be > 0 and latency_budget_s, "
                       "stamp_latency_max_s >= 0");
  }
  // What the driver can count on from a stamp: DOUT mode's end less the stamp's lateness.
  const double window_s = kDoutEndClocks / config.fclk_hz - config.stamp_latency_max_s;
  const double transfer_s = 24.0 / config.spi_speed_hz;
  if (config.latency_budget_s + transfer_s > window_s) {
    return Error::make(ErrorCode::invalid_config,
                       "ADS1251: at fclk %.0f Hz the DOUT window is %.1f us from a stamp up to %.1f us late, "
                       "shorter than the latency budget %.1f us + 24 bits at %u Hz (%.1f us): reads would mix two "
                       "conversions; lower the ADC clock or raise the SPI speed",
                       config.fclk_hz, window_s * 1e6, config.stamp_latency_max_s * 1e6,
                       config.latency_budget_s * 1e6, config.spi_speed_hz, transfer_s * 1e6);
  }
  return {};
}

Status Ads1251::init() noexcept {
  if (Status s = validate(config_); !s) return s;
  return spi_.configure({.mode = 0, .speed_hz = config_.spi_speed_hz, .bits_per_word = 8});
}

std::int32_t Ads1251::sign_extend_24(std::uint32_t raw) noexcept {
  raw &= 0xFFFFFFu;
  return (raw & 0x800000u) != 0 ? static_cast<std::int32_t>(raw) - 0x1000000
                                : static_cast<std::int32_t>(raw);
}

Result<AdcSample> Ads1251::do_read(double timeout_s) noexcept {
  const double deadline_s = clock_.now_s() + timeout_s;
  for (;;) {
    const Result<double> edge = drdy_.wait_edge(Edge::falling, std::max(deadline_s - clock_.now_s(), 0.0));
    if (!edge) return edge.error();
    const double edge_s = *edge;
    const double since_s = have_edge_ ? edge_s - last_edge_s_ : std::numeric_limits<double>::infinity();
    // An edge stamped up to stamp_latency_max_s after our last transfer may
    // have fallen during it.
    const bool during_transfer = edge_s - config_.stamp_latency_max_s <= last_transfer_end_s_;
    if (since_s < 0.5 * period_s_) {
      // The MSB 12 tCLK after the DRDY edge and our read's data bits are
      // the pin's own; anything else there is noise on the line.
      if (!during_transfer && std::fabs(since_s - hold_off_s_) > msb_tolerance_s_) ++stats_.spurious_edges;
      continue;
    }
    if (during_transfer && since_s < next_drdy_after_s_) continue;  // data bits of a read late in the window
    // The conversions are on the part's crystal grid, so the last DRDY
    // stamp bounds this edge too: a stamp later than stamp_latency_max_s
    // cannot open the window past its end unless the last one was late as well.
    double window_from_s = edge_s;
    if (have_edge_) {
      const auto periods = static_cast<std::uint64_t>(since_s / period_s_ + 0.5);  // since_s > 0
      if (have_read_ && periods > 1) stats_.missed_conversions += periods - 1;
      if (periods <= kGridMemoryPeriods) {
        window_from_s = std::min(edge_s, last_edge_s_ + static_cast<double>(periods) * period_s_);
      }
    }
    have_edge_ = true;
    last_edge_s_ = edge_s;
    if (during_transfer) {
      // The next DRDY fell while a (late) read still clocked: SCLKs inside
      // its pulse have moved its shift pointer.
      if (have_read_) ++stats_.missed_conversions;
      continue;
    }

    double now_s = clock_.now_s();
    if (now_s < edge_s + hold_off_s_) {
      clock_.sleep_until(edge_s + hold_off_s_);
      now_s = clock_.now_s();
    }
    if (now_s + transfer_s_ > window_from_s + window_s_) {
      if (have_read_) ++stats_.missed_conversions;  // woken too late: clocking now would read a mix
      continue;
    }
    static constexpr std::array<std::uint8_t, 3> kZeros{};
    std::array<std::uint8_t, 3> rx{};
    const Status transfer = spi_.transfer(kZeros, rx);
    last_transfer_end_s_ = clock_.now_s();
    if (last_transfer_end_s_ > window_from_s + window_s_) {
      // Mixed data. No drain: the next DRDY edge may be queued already, and
      // must be seen to skip the conversion whose pulse these SCLKs hit.
      ++stats_.late_reads;
      if (!transfer) return transfer.error();
      continue;
    }
    // The data bits' own edges; any arriving later fall before last_transfer_end_s_.
    (void)drdy_.discard_edges();
    if (!transfer) return transfer.error();
    AdcSample sample;
    sample.code = sign_extend_24(static_cast<std::uint32_t>(rx[0]) << 16 |
                                 static_cast<std::uint32_t>(rx[1]) << 8 | rx[2]);
    sample.clipped = sample.code >= kCodeMax || sample.code <= kCodeMin;
    sample.gyro_mv = code_to_mv(sample.code);
    sample.time_s = edge_s;
    have_read_ = true;
    return sample;
  }
}

}  // namespace gyrotc::hal
