#pragma once

#include "gyrotc/hal/chips/ad5060.hpp"
#include "gyrotc/hal/chips/opa548.hpp"
#include "gyrotc/hal/devices.hpp"

namespace gyrotc::hal {

// The TEC stage: AD5060 #2 drives the OPA548, which turns the DAC voltage
// into TEC current around mid-scale: I = (Vdac - Vref/2) * gain_a_per_v.
struct TecStageConfig {
  double gain_a_per_v = 1.0;
  double current_limit_a = 1.5;
};

class TecStage final : public TecDriver {
 public:
  TecStage(Ad5060& dac, Opa548& amplifier, const TecStageConfig& config) noexcept
      : dac_(dac), amplifier_(amplifier), config_(config) {}

  double drive_v_for(double current_a) const noexcept;
  double last_current_a() const noexcept { return last_current_a_; }
  const TecStageConfig& config() const noexcept { return config_; }

 private:
  Status do_set_current_a(double current_a) noexcept override;
  Status do_enable(bool on) noexcept override;
  Result<ThermalStatus> do_thermal_status() noexcept override;
  bool do_senses_thermal() const noexcept override { return amplifier_.has_sense(); }
  Status do_safe_off() noexcept override;

  Ad5060& dac_;
  Opa548& amplifier_;
  TecStageConfig config_;
  double last_current_a_ = 0.0;
};

}  // namespace gyrotc::hal
