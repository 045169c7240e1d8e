// The part of GpiodLine that does not depend on the libgpiod API version;
// gpiod_line_v1.cpp or gpiod_line_v2.cpp holds the rest (hal/CMakeLists.txt
// builds the one matching the libgpiod found).
#include "gyrotc/hal/linux/gpiod_line.hpp"

namespace gyrotc::hal {

namespace {
const char* edge_name(Edge edge) noexcept { return edge == Edge::rising ? "rising" : "falling"; }
}  // namespace

Status GpiodLine::check_settable() const noexcept {
  if (mode_ != GpioMode::output) {
    return Error::make(ErrorCode::invalid_config, "GPIO '%s' is not an output", name_.c_str());
  }
  return {};
}

Status GpiodLine::check_edge(Edge edge) const noexcept {
  if (mode_ != GpioMode::edge_events) {
    return Error::make(ErrorCode::invalid_config, "GPIO '%s' was not requested for edge events", name_.c_str());
  }
  if (edge != edge_) {
    return Error::make(ErrorCode::invalid_config, "GPIO '%s' was requested for %s edges, not %s ones",
                       name_.c_str(), edge_name(edge_), edge_name(edge));
  }
  return {};
}

}  // namespace gyrotc::hal
