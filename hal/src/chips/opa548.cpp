#include "gyrotc/hal/chips/opa548.hpp"

namespace gyrotc::hal {

Status Opa548::enable(bool on) noexcept {
  Status s = drive_.set(on);
  // A failed disable may have left the pin anywhere: keep treating it as
  // possibly enabled so that the caller's retry is not skipped.
  if (s || on) enabled_ = on && s.ok();
  return s;
}

Result<ThermalStatus> Opa548::thermal_status() noexcept {
  if (sense_ == nullptr || !enabled_) return ThermalStatus::unknown;
  const Result<bool> level = sense_->get();
  if (!level) return level.error();
  return *level ? ThermalStatus::clear : ThermalStatus::shutdown;
}

std::string_view to_string(ThermalStatus status) noexcept {
  switch (status) {
    case ThermalStatus::clear: return "clear";
    case ThermalStatus::shutdown: return "thermal shutdown";
    case ThermalStatus::unknown: return "unknown";
  }
  return "unknown";
}

}  // namespace gyrotc::hal
