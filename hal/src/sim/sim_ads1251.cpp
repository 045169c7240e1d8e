#include "gyrotc/hal/sim/sim_ads1251.hpp"

#include <algorithm>
#include <cmath>

#include "gyrotc/hal/chips/ads1251.hpp"

namespace gyrotc::hal {

SimAds1251::SimAds1251(Input& input, Clock& clock, const Config& config) noexcept
    : input_(input),
      clock_(clock),
      config_(config),
      period_s_(Ads1251::kClocksPerSample / config.fclk_hz),
      window_s_(Ads1251::kDoutWindowClocks / config.fclk_hz),
      codes_per_mv_(8388608.0 / (config.vref_v * 1000.0)) {
  last_index_ = static_cast<std::int64_t>(std::floor(clock.now_s() / period_s_));
}

std::int32_t SimAds1251::code_for_mv(double mv) const noexcept {
  const double code = mv * codes_per_mv_;
  if (!(code < Ads1251::kCodeMax)) return std::isnan(code) ? 0 : Ads1251::kCodeMax;
  if (code <= Ads1251::kCodeMin) return Ads1251::kCodeMin;
  // Round half away from zero; cheaper than nearbyint on the per-sample path.
  return static_cast<std::int32_t>(code + (code < 0.0 ? -0.5 : 0.5));
}

Status SimAds1251::Bus::do_configure(const SpiConfig& config) noexcept {
  if (config.mode != 0 || config.bits_per_word != 8) {
    return Error::make(ErrorCode::invalid_config,
                       "sim:ads1251: SPI mode %u, %u bits per word; the ADS1251 is read in mode 0, 8 bits",
                       config.mode, config.bits_per_word);
  }
  chip_.spi_mode_ = config.mode;
  return {};
}

Status SimAds1251::Bus::do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
  SimAds1251& c = chip_;
  if (c.spi_error_.load(std::memory_order_relaxed)) {
    return Error::make(ErrorCode::io, "sim:ads1251: SPI transfer failed (injected fault)");
  }
  if (c.spi_mode_ != 0) return Error::make(ErrorCode::invalid_config, "sim:ads1251: SPI not configured");
  if (tx.size() != rx.size()) return Error::make(ErrorCode::invalid_config, "sim:ads1251: tx/rx sizes differ");
  std::uint32_t frame = c.frame_;
  if (c.data_ready_ && c.clock_.now_s() - c.edge_time_s_ > c.window_s_) {
    // Past the DOUT window the output register already holds part of the
    // next conversion.
    const double next_t = static_cast<double>(c.last_index_ + 1) * c.period_s_;
    const auto next = static_cast<std::uint32_t>(c.code_for_mv(c.input_.input_mv(next_t))) & 0xFFFFFFu;
    frame = (frame & 0xFFF000u) | (next & 0x000FFFu);
    ++c.late_reads_;
  }
  for (std::size_t i = 0; i < rx.size(); ++i) {
    rx[i] = i < 3 ? static_cast<std::uint8_t>(frame >> (16 - 8 * i)) : std::uint8_t{0};
  }
  c.data_ready_ = false;
  ++c.reads_;
  return {};
}

Status SimAds1251::Drdy::do_set(bool) noexcept {
  return Error::make(ErrorCode::invalid_config, "sim:ads1251-drdy is an input");
}

Result<bool> SimAds1251::Drdy::do_get() noexcept { return !chip_.data_ready_; }

Result<double> SimAds1251::Drdy::do_wait_edge(Edge edge, double timeout_s) noexcept {
  SimAds1251& c = chip_;
  const double now_s = c.clock_.now_s();
  // The first conversion completing after now (edges already past are not
  // queued), and never the one already announced. Usually that is simply the
  // next one.
  std::int64_t k = c.last_index_ + 1;
  double t_edge = static_cast<double>(k) * c.period_s_;
  if (now_s >= t_edge) {
    k = std::max(k, static_cast<std::int64_t>(std::floor(now_s / c.period_s_)) + 1);
    t_edge = static_cast<double>(k) * c.period_s_;
  }
  if (edge != Edge::falling || c.stall_.load(std::memory_order_relaxed) || t_edge - now_s > timeout_s) {
    c.clock_.sleep_until(now_s + timeout_s);
    return Error::make(ErrorCode::timeout, "sim:ads1251: no DRDY %s edge within %.3f s",
                       edge == Edge::falling ? "falling" : "rising", timeout_s);
  }
  c.clock_.sleep_until(t_edge);
  c.last_index_ = k;
  c.edge_time_s_ = t_edge;
  c.frame_ = static_cast<std::uint32_t>(c.code_for_mv(c.input_.input_mv(t_edge))) & 0xFFFFFFu;
  c.data_ready_ = true;
  return t_edge;
}

}  // namespace gyrotc::hal
