#include "gyrotc/app/runtime/rate_output.hpp"

#include <algorithm>
#include <cmath>

#include "gyrotc/app/runtime/controller_flags.hpp"

namespace gyrotc::app {

SampleResult RateOutput::on_sample(const hal::AdcSample& sample, double temp_c, bool have_casing) noexcept {
  const fit::Compensator* compensator = compensator_.load(std::memory_order_acquire);
  // The modelled bias only changes with the casing reading (about once a
  // second) or the model: evaluate it then, and subtract it from every sample.
  if (compensator != cached_compensator_ || !bias_cached_) {
    cached_temp_c_ = temp_c;
    const fit::Compensated c = compensator->compensate(0.0, temp_c);
    cached_compensator_ = compensator;
    cached_bias_mv_ = c.bias_mv;
    // Before the first casing reading there is no temperature to be outside
    // the calibrated range: the rate is invalid (NaN bias), not clamped.
    cached_clamped_ = have_casing && c.temp_clamped;
    inverse_scale_ = 1.0 / compensator->scale_mv_per_dps();
    bias_cached_ = true;
    // Release: every use of an older compensator happens before a reader sees this one.
    in_use_.store(compensator, std::memory_order_release);
  }
  SampleResult result;
  set_flag(flags_, kFlagModelClamped, cached_clamped_);
  const double rate_dps = (sample.gyro_mv - cached_bias_mv_) * inverse_scale_;
  result.valid = !sample.clipped && std::isfinite(rate_dps);
  set_flag(flags_, kFlagAdcInvalid, sample.clipped);
  result.bias_mv = cached_bias_mv_;
  const double mid_v = 0.5 * vref_v_;
  if (result.valid) {
    result.rate_dps = rate_dps;
    result.rate_out_v = std::clamp(mid_v + rate_dps * v_per_dps_, 0.0, vref_v_);
  } else {
    result.rate_dps = std::numeric_limits<double>::quiet_NaN();
    result.rate_out_v = mid_v;
  }
  return result;
}

void RateOutput::on_adc_timeout() noexcept { set_flag(flags_, kFlagAdcInvalid, true); }

void RateOutput::on_rate_dac_write(bool ok) noexcept { set_flag(flags_, kFlagRateDacFailed, !ok); }

}  // namespace gyrotc::app
