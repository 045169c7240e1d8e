#include "gyrotc/hal/sim/sim_opa548.hpp"

namespace gyrotc::hal {

bool SimOpa548::sense_high() const noexcept {
  if (!output_enabled()) return false;
  return clock_ == nullptr || clock_->now_s() - released_at_s_.load(std::memory_order_relaxed) >= sense_delay_s_;
}

Status SimOpa548::Drive::do_set(bool high) noexcept {
  if (high && !chip_.drive_released() && chip_.clock_ != nullptr) {
    chip_.released_at_s_.store(chip_.clock_->now_s(), std::memory_order_relaxed);
  }
  chip_.released_.store(high, std::memory_order_relaxed);
  if (chip_.listener_ != nullptr) chip_.listener_->on_opa548_drive(high);
  return {};
}

Result<double> SimOpa548::Drive::do_wait_edge(Edge, double) noexcept {
  return Error::make(ErrorCode::invalid_config, "sim:opa548-es-drive has no edge events");
}

Status SimOpa548::Sense::do_set(bool) noexcept {
  return Error::make(ErrorCode::invalid_config, "sim:opa548-es-sense is an input");
}

Result<double> SimOpa548::Sense::do_wait_edge(Edge, double) noexcept {
  return Error::make(ErrorCode::invalid_config, "sim:opa548-es-sense has no edge events");
}

}  // namespace gyrotc::hal
