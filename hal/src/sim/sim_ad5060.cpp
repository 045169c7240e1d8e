#include "gyrotc/hal/sim/sim_ad5060.hpp"

#include <algorithm>

namespace gyrotc::hal {

Status SimAd5060::do_configure(const SpiConfig& config) noexcept {
  if (config.mode != 1 || config.bits_per_word != 8) {
    return Error::make(ErrorCode::invalid_config,
                       "%s: SPI mode %u, %u bits per word; the AD5060 is written in mode 1, 8 bits",
                       name_.c_str(), config.mode, config.bits_per_word);
  }
  configured_ = true;
  return {};
}

Status SimAd5060::do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
  if (!configured_) return Error::make(ErrorCode::invalid_config, "%s: SPI not configured", name_.c_str());
  if (tx.size() != 3) {
    std::fill(rx.begin(), rx.end(), std::uint8_t{0});  // the AD5060 has no data output
    ++ignored_frames_;
    return {};
  }
  rx[0] = rx[1] = rx[2] = 0;
  const std::uint32_t word = static_cast<std::uint32_t>(tx[0]) << 16 | static_cast<std::uint32_t>(tx[1]) << 8 | tx[2];
  code_ = static_cast<std::uint16_t>(word & 0xFFFFu);
  mode_ = static_cast<Ad5060PowerDown>((word >> 16) & 3u);
  const double v = mode_ == Ad5060PowerDown::normal ? v_per_code_ * code_ : 0.0;
  output_v_.store(v, std::memory_order_relaxed);
  ++frames_;
  if (listener_ != nullptr) listener_->on_dac_output(v, mode_);
  return {};
}

}  // namespace gyrotc::hal
