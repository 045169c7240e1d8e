#pragma once

#include <chrono>

namespace gyrotc::app {

// Wall time since `start` on the monotonic clock, in seconds.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace gyrotc::app
