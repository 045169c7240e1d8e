#include "gyrotc/hal/sim/sim_opa548.hpp"

namespace gyrotc::hal {

Status SimOpa548::Drive::do_set(bool high) noexcept {
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
