#include "gyrotc/hal/sim/sim_ad5060.hpp"

#include <algorithm>

namespace gyrotc::hal {

namespace {
constexpr std::uint32_t kMaxSclkHz = 30'000'000;  // datasheet t1: SCLK cycle time >= 33 ns
}  // namespace

Status SimAd5060::do_configure(const SpiConfig& config) noexcept {
  // Any mode is accepted, as by the part: a wrong one shows in the data.
  // Words other than 8 bits are the controller's business (spidev packs
  // them into bytes on the wire).
  if (config.mode > 3 || config.bits_per_word != 8 || config.speed_hz == 0) {
    return Error::make(ErrorCode::invalid_config,
                       "%s: SPI mode %u, %u bits per word, %u Hz: the bus needs mode 0..3, 8-bit bytes on the "
                       "wire and a clock",
                       name_.c_str(), config.mode, config.bits_per_word, config.speed_hz);
  }
  spi_mode_ = config.mode;
  speed_hz_ = config.speed_hz;
  configured_ = true;
  return {};
}

Status SimAd5060::do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
  if (spi_error_.load(std::memory_order_relaxed)) {
    return Error::make(ErrorCode::io, "%s: SPI transfer failed (injected fault)", name_.c_str());
  }
  if (!configured_) return Error::make(ErrorCode::invalid_config, "%s: SPI not configured", name_.c_str());
  if (tx.size() != 3 || rx.size() != 3 || speed_hz_ > kMaxSclkHz) {
    for (std::uint8_t& b : rx) b = 0;  // the AD5060 has no data output
    ++ignored_frames_;
    return {};
  }
  rx[0] = rx[1] = rx[2] = 0;  // (three stores: a loop here became a memset call per sample)
  std::uint32_t word = static_cast<std::uint32_t>(tx[0]) << 16 | static_cast<std::uint32_t>(tx[1]) << 8 | tx[2];
  if (spi_mode_ == 0) word = (word << 1) & 0xFFFFFFu;  // each latch takes the next bit (see the header)
  code_ = static_cast<std::uint16_t>(word & 0xFFFFu);
  mode_ = static_cast<Ad5060PowerDown>((word >> 16) & 3u);
  const double v = mode_ == Ad5060PowerDown::normal ? v_per_code_ * code_ : 0.0;
  output_v_.store(v, std::memory_order_relaxed);
  ++frames_;
  if (listener_ != nullptr) listener_->on_dac_output(v, mode_);
  return {};
}

}  // namespace gyrotc::hal
