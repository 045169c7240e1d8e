#include "gyrotc/hal/chips/opa548.hpp"

namespace gyrotc::hal {

Status Opa548::enable(bool on) noexcept {
  Status s = drive_.set(on);
  // A failed disable may have left the pin anywhere: keep treating it as
  // possibly enabled so that the caller's retry is not skipped.
  if (s || on) enabled_ = on && s.ok();
  return s;
}

Result<bool> Opa548::thermal_flag() noexcept {
  if (!enabled_) return false;  // E/S is held low by us: no information
  Result<bool> level = sense_ != nullptr ? sense_->get() : drive_.get();
  if (!level) return level.error();
  return !*level;
}

}  // namespace gyrotc::hal
