#pragma once

#include <optional>
#include <string_view>

#include "gyrotc/hal/result.hpp"

namespace gyrotc::hal {

// An exclusive lock (flock, LOCK_EX | LOCK_NB) on an open device node, held
// until the descriptor is closed or the process ends. Every gyrotc takes it
// on each spidev before it writes anything, so a second instance (probe,
// record or safe-off while the service runs) stops before touching a DAC.
// Busy: ErrorCode::busy, "'<path>' is already in use by PID <n> (<name>)",
// the holder found in /proc/locks ("by another process" when it cannot be).
Status lock_device(int fd, std::string_view path) noexcept;

// The PID holding a flock on the file open at fd, from a /proc/locks-format
// table (`locks_path`), if any.
std::optional<int> flock_holder(int fd, const char* locks_path = "/proc/locks") noexcept;

}  // namespace gyrotc::hal
