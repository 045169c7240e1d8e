#include "gyrotc/app/runtime/controller_flags.hpp"

namespace gyrotc::app {

const char* flag_name(std::uint32_t flag) noexcept {
  switch (flag) {
    case kFlagTempStale: return "temp_stale";
    case kFlagTempInvalid: return "temp_invalid";
    case kFlagTempStuck: return "temp_stuck";
    case kFlagOverTempLatched: return "over_temp_latched";
    case kFlagOpa548Thermal: return "opa548_thermal";
    case kFlagAdcInvalid: return "adc_invalid";
    case kFlagModelClamped: return "model_clamped";
    case kFlagTecSaturated: return "tec_saturated";
    case kFlagTecOff: return "tec_off";
    case kFlagAdcStalled: return "adc_stalled";
    case kFlagTecWriteFailed: return "tec_write_failed";
    case kFlagRateDacFailed: return "rate_dac_failed";
    case kFlagUncontrolled: return "uncontrolled";
    case kFlagAmbientStale: return "ambient_stale";
    case kFlagLoopRunaway: return "loop_runaway";
    default: return "";
  }
}

std::string flag_names(std::uint32_t flags) {
  std::string names;
  for (unsigned bit = 0; bit < 32; ++bit) {
    const std::uint32_t flag = 1u << bit;
    if ((flags & flag) == 0) continue;
    const std::string name = flag_name(flag);
    names += (names.empty() ? "" : "+") + (name.empty() ? "bit " + std::to_string(bit) : name);
  }
  return names.empty() ? "none" : names;
}

}  // namespace gyrotc::app
