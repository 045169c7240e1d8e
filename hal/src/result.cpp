#include "gyrotc/hal/result.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>

namespace gyrotc::hal {

std::string_view to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::io: return "i/o error";
    case ErrorCode::timeout: return "timeout";
    case ErrorCode::not_found: return "not found";
    case ErrorCode::invalid_config: return "invalid configuration";
    case ErrorCode::bad_data: return "bad data";
    case ErrorCode::fault: return "device fault";
    case ErrorCode::busy: return "device busy";
  }
  return "unknown";
}

Error Error::make(ErrorCode code, const char* format, ...) noexcept {
  Error e;
  e.code_ = code;
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(e.text_.data(), e.text_.size(), format, args);
  va_end(args);
  e.length_ = static_cast<std::uint8_t>(std::clamp(n, 0, static_cast<int>(kMaxMessage)));
  return e;
}

Error Error::from_errno(int errno_value, std::string_view what, std::string_view path) noexcept {
  // strerror_r (GNU variant) is thread-safe, unlike strerror.
  char buffer[96];
  const char* text = strerror_r(errno_value, buffer, sizeof buffer);
  Error e = make(errno_value == ENOENT ? ErrorCode::not_found : ErrorCode::io, "%.*s '%.*s': %s",
                 static_cast<int>(what.size()), what.data(), static_cast<int>(path.size()),
                 path.data(), text);
  e.errno_value_ = errno_value;
  return e;
}

}  // namespace gyrotc::hal
