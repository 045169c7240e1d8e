#include "gyrotc/hal/chips/tec_stage.hpp"

#include <algorithm>
#include <cmath>

namespace gyrotc::hal {

double TecStage::drive_v_for(double current_a) const noexcept {
  return dac_.config().vref_v / 2.0 + current_a / config_.gain_a_per_v;
}

Status TecStage::do_set_current_a(double current_a) noexcept {
  if (std::isnan(current_a)) current_a = 0.0;
  current_a = std::clamp(current_a, -config_.current_limit_a, config_.current_limit_a);
  Status s = dac_.write_v(drive_v_for(current_a));
  if (s) last_current_a_ = current_a;
  return s;
}

Status TecStage::do_enable(bool on) noexcept { return amplifier_.enable(on); }

Result<ThermalStatus> TecStage::do_thermal_status() noexcept { return amplifier_.thermal_status(); }

Status TecStage::do_safe_off() noexcept {
  const Status dac = do_set_current_a(0.0);
  const Status amp = amplifier_.enable(false);
  return dac ? amp : dac;
}

}  // namespace gyrotc::hal
