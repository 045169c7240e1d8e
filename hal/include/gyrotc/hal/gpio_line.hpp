#pragma once

#include <cstdint>
#include <string_view>

#include "gyrotc/hal/result.hpp"

namespace gyrotc::hal {

enum class Edge : std::uint8_t { rising, falling };

// One GPIO line. Its direction (output, input, edge events) is fixed when
// the back-end requests it; calls that do not fit the direction fail.
class GpioLine {
 public:
  virtual ~GpioLine() = default;

  // Drive an output line (true = high / released for open drain).
  Status set(bool high) noexcept { return do_set(high); }
  // The level of the line.
  Result<bool> get() noexcept { return do_get(); }
  // Block until the next `edge` (others are skipped) or until timeout_s has
  // passed (ErrorCode::timeout). Returns the monotonic time of the edge, s.
  Result<double> wait_edge(Edge edge, double timeout_s) noexcept { return do_wait_edge(edge, timeout_s); }
  // Drop every edge event queued so far, without blocking; returns how many
  // were dropped. A line not requested for edge events has none.
  Result<int> discard_edges() noexcept { return do_discard_edges(); }
  // Chip and line, for messages.
  std::string_view name() const noexcept { return do_name(); }

 private:
  virtual Status do_set(bool high) noexcept = 0;
  virtual Result<bool> do_get() noexcept = 0;
  virtual Result<double> do_wait_edge(Edge edge, double timeout_s) noexcept = 0;
  virtual std::string_view do_name() const noexcept = 0;
  virtual Result<int> do_discard_edges() noexcept { return 0; }
};

}  // namespace gyrotc::hal
