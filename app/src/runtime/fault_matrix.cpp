#include "gyrotc/app/runtime/fault_matrix.hpp"

#include "gyrotc/app/runtime/controller_flags.hpp"

namespace gyrotc::app {
namespace {

constexpr FaultEntry kMatrix[] = {
    {kFlagTempStale, "casing DS18B20 (unplugged, bus held, every read fails)", TecPath::off, RateOutputState::uncontrolled,
     "no valid casing reading for failsafe.stale_periods PID periods: TEC off, the rate compensated at the last valid "
     "reading",
     "failsafe.recovery_readings good readings; the loop restarts with its integral"},
    {kFlagTempInvalid, "casing DS18B20 (CRC error, 85 C power-on value, all-zero scratchpad, range, resolution)",
     TecPath::held, RateOutputState::compensated,
     "invalid casing reading (empty, CRC, 85 C, range, resolution, missing): TEC current held",
     "failsafe.recovery_readings good readings"},
    {kFlagTempStuck, "casing DS18B20 (the same valid reading for ever)", TecPath::off, RateOutputState::uncontrolled,
     "the casing reading does not change while the TEC drives, or (model-based loop) where its model says it must: "
     "TEC off, the rate compensated at the last reading",
     "failsafe.recovery_readings readings of another value"},
    {kFlagOverTempLatched, "the casing (a reading at or above failsafe.over_temp_c)", TecPath::off,
     RateOutputState::uncontrolled, "casing above failsafe.over_temp_c: TEC off until restart",
     "a restart of the daemon"},
    {kFlagOpa548Thermal, "OPA548 (thermal shutdown, E/S low)", TecPath::off, RateOutputState::uncontrolled,
     "OPA548 thermal shutdown (E/S low): TEC off for failsafe.opa548_cooldown_s",
     "failsafe.opa548_cooldown_s, then a read of E/S without the flag"},
    {kFlagTecWriteFailed, "TEC DAC or the E/S line (SPI or GPIO error)", TecPath::off, RateOutputState::uncontrolled,
     "the TEC DAC or the OPA548's E/S line refused a write (SPI or GPIO error): TEC off, retried every PID period",
     "the first period whose command the path takes; the loop restarts with its integral"},
    {kFlagAdcInvalid, "ADS1251 (a DRDY timeout, a clipped sample)", TecPath::drives, RateOutputState::invalid,
     "ADS1251 DRDY timeout or clipped sample: rate output invalid (DAC at mid-scale)", "the next good sample"},
    {kFlagAdcStalled, "ADS1251 (DRDY stopped, every read fails)", TecPath::drives, RateOutputState::invalid,
     "no ADS1251 sample for failsafe.adc_stall_s (DRDY stopped or every read fails): rate output invalid (DAC at "
     "mid-scale), the temperature loop goes on",
     "the next good sample"},
    {kFlagRateDacFailed, "rate DAC (SPI error)", TecPath::drives, RateOutputState::stale,
     "the rate DAC refused a write (SPI error): the analog rate output is stale", "the next write it takes"},
    {kFlagAmbientStale, "ambient DS18B20 (unplugged, CRC, any invalid reading)", TecPath::drives,
     RateOutputState::compensated,
     "no valid ambient reading for failsafe.ambient_stale_s: the loop goes on with the last one (feed-forward, the "
     "model-based loop's input)",
     "the next valid ambient reading"},
    {kFlagLoopRunaway, "the model-based loop (a model far off where its record did not look)",
     TecPath::pid, RateOutputState::compensated,
     "the model-based loop drove the casing reading away from the setpoint for failsafe.runaway_s (by "
     "failsafe.runaway_c): the PID holds in its place",
     "a reload that brings another controller, or a restart"},
    {kFlagModelClamped, "the calibration (the casing or die outside its range; not a fault)", TecPath::drives,
     RateOutputState::clamped, "casing (or die) temperature outside the calibration's range: compensated at its end",
     "a compensation temperature inside the range"},
};

}  // namespace

std::span<const FaultEntry> fault_matrix() noexcept { return kMatrix; }

const char* fault_consequence(std::uint32_t flag) noexcept {
  for (const FaultEntry& e : kMatrix) {
    if (e.flag == flag) return e.consequence;
  }
  return "";
}

const char* describe(TecPath tec) noexcept {
  switch (tec) {
    case TecPath::drives: return "drives";
    case TecPath::held: return "current held";
    case TecPath::off: return "off (0 A, OPA548 disabled)";
    case TecPath::pid: return "the PID drives (in the model-based loop's place)";
  }
  return "";
}

const char* describe(RateOutputState rate) noexcept {
  switch (rate) {
    case RateOutputState::compensated: return "compensated";
    case RateOutputState::clamped: return "compensated at the calibration's end";
    case RateOutputState::uncontrolled: return "compensated at the last valid reading, flagged `uncontrolled`";
    case RateOutputState::invalid: return "invalid: DAC at mid-scale, no rate in the record";
    case RateOutputState::stale: return "stale: the DAC holds the last value it took";
  }
  return "";
}

std::string fault_matrix_markdown() {
  std::string out =
      "| flag | what failed | TEC path | rate output | journal: `fault NAME: ...` | cleared by |\n"
      "|---|---|---|---|---|---|\n";
  for (const FaultEntry& e : kMatrix) {
    out += std::string("| `") + flag_name(e.flag) + "` | " + e.device + " | " + describe(e.tec) + " | " +
           describe(e.rate) + " | " + e.consequence + " | " + e.clears + " |\n";
  }
  return out;
}

}  // namespace gyrotc::app
