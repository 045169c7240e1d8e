#pragma once

#include <cstdint>
#include <string>

// The flags the Controller reports with every sample and TEC command: one
// word, each bit owned by the part of the controller that raises it
// (runtime/rate_output, runtime/fault_supervisor, runtime/tec_loop).
namespace gyrotc::app {

enum ControllerFlag : std::uint32_t {
  kFlagTempStale = 1u << 0,       // no valid casing reading measured in the last stale_periods PID periods
  kFlagTempInvalid = 1u << 1,     // an invalid casing reading (CRC, 85 C reset, range) since the last M good ones
  kFlagTempStuck = 1u << 2,       // the casing reading has not changed while the TEC drives
  kFlagOverTempLatched = 1u << 3, // casing over-temperature: TEC off until restart
  kFlagOpa548Thermal = 1u << 4,   // the OPA548 reports thermal shutdown
  kFlagAdcInvalid = 1u << 5,      // ADC timeout or clipped sample: the rate output is invalid
  kFlagModelClamped = 1u << 6,    // compensation temperature outside the calibrated range
  kFlagTecSaturated = 1u << 7,    // the PID output is at its limit
  kFlagTecOff = 1u << 8,          // the TEC is commanded off (0 A, OPA548 disabled)
  kFlagAdcStalled = 1u << 9,      // no ADC sample for adc_stall_s: the rate output invalid, the TEC loop goes on
  kFlagTecWriteFailed = 1u << 10, // the TEC DAC or the OPA548's E/S line refused the command: TEC off, retried
  kFlagRateDacFailed = 1u << 11,  // the rate DAC refused the compensated output: the analog rate is stale
  kFlagUncontrolled = 1u << 12,   // a fault stopped the TEC: the rate is compensated at a temperature not held
  kFlagAmbientStale = 1u << 13,   // no valid ambient reading for ambient_stale_s: the loop uses the last one
  kFlagLoopRunaway = 1u << 14,    // the model-based loop drove the reading away from the setpoint: the PID holds
};

// The faults: the flags that stop the TEC path or make the rate output
// invalid. model_clamped, tec_saturated, tec_off and uncontrolled report
// what the controller does, not a fault of the board.
inline constexpr std::uint32_t kFaultFlags = kFlagTempStale | kFlagTempInvalid | kFlagTempStuck |
                                             kFlagOverTempLatched | kFlagOpa548Thermal | kFlagAdcInvalid |
                                             kFlagAdcStalled | kFlagTecWriteFailed | kFlagRateDacFailed |
                                             kFlagAmbientStale | kFlagLoopRunaway;
// The faults of the TEC path (the casing sensor, the OPA548, the TEC DAC):
// while one of them has the TEC off, the rate output is flagged uncontrolled.
inline constexpr std::uint32_t kTecPathFaults = kFlagTempStale | kFlagTempInvalid | kFlagTempStuck |
                                                kFlagOverTempLatched | kFlagOpa548Thermal | kFlagTecWriteFailed;

// The flags the journal tells as they are raised and cleared (with the words
// of runtime/fault_matrix): the faults, and model_clamped.
inline constexpr std::uint32_t kJournalFlags = kFaultFlags | kFlagModelClamped;

// The name of each flag bit (for the journal); "" for a bit that is none.
const char* flag_name(std::uint32_t flag) noexcept;
// Every flag set in `flags` by name, joined by '+' ("tec_off+model_clamped"),
// "none" for none and "bit N" for a bit that is no flag: what a person reads
// in place of the CSV's number.
std::string flag_names(std::uint32_t flags);

// Sets or clears `flag` in `flags`.
constexpr void set_flag(std::uint32_t& flags, std::uint32_t flag, bool on) noexcept {
  flags = on ? (flags | flag) : (flags & ~flag);
}

}  // namespace gyrotc::app
