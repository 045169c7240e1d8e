#pragma once

#include <atomic>
#include <cstdint>
#include <limits>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/hal/devices.hpp"

// The Controller's rate path: every ADC sample compensated at the
// compensation temperature and turned into the rate DAC's voltage. Owns the
// flags adc_invalid, model_clamped and rate_dac_failed. Allocation-free,
// lock-free; the compensator may be swapped from another thread.
namespace gyrotc::app {

struct SampleResult {
  double rate_dps = 0.0;    // compensated rate (NaN when not valid)
  double bias_mv = 0.0;     // modelled zero-rate output subtracted
  double rate_out_v = 0.0;  // for the rate DAC (mid-scale when not valid)
  bool valid = false;
  std::uint32_t flags = 0;
};

class RateOutput {
 public:
  // The Compensator is not owned: it must outlive its use (see set_compensator).
  RateOutput(double rate_dac_vref_v, double rate_out_v_per_dps, const fit::Compensator& compensator) noexcept
      : vref_v_(rate_dac_vref_v), v_per_dps_(rate_out_v_per_dps), compensator_(&compensator), in_use_(&compensator) {}

  // One sample at the compensation temperature temp_c (have_casing false:
  // none yet, the rate is invalid). SampleResult::flags is left to the caller.
  SampleResult on_sample(const hal::AdcSample& sample, double temp_c, bool have_casing) noexcept;
  // The ADC did not deliver in time: invalid until the next good sample.
  void on_adc_timeout() noexcept;
  // Whether the rate DAC took the last output.
  void on_rate_dac_write(bool ok) noexcept;
  // The compensation temperature moved: the bias is evaluated again.
  void on_temperature(double temp_c) noexcept {
    if (temp_c != cached_temp_c_) bias_cached_ = false;
  }

  void set_compensator(const fit::Compensator& compensator) noexcept {
    compensator_.store(&compensator, std::memory_order_release);
  }
  const fit::Compensator& compensator() const noexcept { return *compensator_.load(std::memory_order_acquire); }
  const fit::Compensator* compensator_in_use() const noexcept { return in_use_.load(std::memory_order_acquire); }
  // The scale of the compensator last used.
  double scale_mv_per_dps() const noexcept { return 1.0 / inverse_scale_; }
  std::uint32_t flags() const noexcept { return flags_; }

 private:
  double vref_v_;
  double v_per_dps_;
  std::atomic<const fit::Compensator*> compensator_;
  std::atomic<const fit::Compensator*> in_use_;
  std::uint32_t flags_ = 0;
  // The bias at the current temperature and model.
  const fit::Compensator* cached_compensator_ = nullptr;
  double cached_temp_c_ = std::numeric_limits<double>::quiet_NaN();
  bool bias_cached_ = false;
  double cached_bias_mv_ = 0.0;
  bool cached_clamped_ = false;
  double inverse_scale_ = 1.0;
};

}  // namespace gyrotc::app
