#pragma once

#include <cstdint>
#include <span>
#include <string>

// Each flag the journal tells, what it stops and what goes on: the policy
// Controller::decide and the runners carry out, written down once. The
// journal's words and docs/FAULTS.md come from it, and a test holds the
// controller to it (tests/app/controller/fault_matrix_test.cpp).
namespace gyrotc::app {

// What the TEC path does while the flag is raised.
enum class TecPath {
  drives,  // the loop goes on
  held,    // the last current, until the reading goes stale
  off,     // 0 A, the OPA548 disabled
  pid,     // the PID drives in the model-based loop's place
};

// What the rate output does while the flag is raised.
enum class RateOutputState {
  compensated,   // as usual
  clamped,       // compensated at the calibration's end
  uncontrolled,  // compensated at the last valid casing reading, flagged uncontrolled
  invalid,       // the DAC at mid-scale (zero rate), the record's rate empty
  stale,         // the DAC refuses writes: its output is the last it took
};

struct FaultEntry {
  std::uint32_t flag;
  const char* device;       // what failed
  TecPath tec;
  RateOutputState rate;
  const char* consequence;  // the journal's "fault NAME: ..." line
  const char* clears;       // what clears it
};

std::span<const FaultEntry> fault_matrix() noexcept;
// The entry's journal line for `flag`; "" for a flag that has no entry.
const char* fault_consequence(std::uint32_t flag) noexcept;
const char* describe(TecPath tec) noexcept;
const char* describe(RateOutputState rate) noexcept;
// The matrix as the Markdown table docs/FAULTS.md holds.
std::string fault_matrix_markdown();

}  // namespace gyrotc::app
