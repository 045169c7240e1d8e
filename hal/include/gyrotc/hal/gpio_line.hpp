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
  // The oldest queued edge event of kind `edge` (others before it are
  // dropped), waiting at most timeout_s for one (ErrorCode::timeout). Events
  // queue as the kernel's do, from the line's request on: one queued long
  // ago comes back at once. Returns the CLOCK_MONOTONIC time of the edge
  // itself (the event's stamp, however old), s.
  Result<double> wait_edge(Edge edge, double timeout_s) noexcept { return do_wait_edge(edge, timeout_s); }
  // Drop every edge event readable so far, without blocking; returns how
  // many were dropped. A line not requested for edge events has none.
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
