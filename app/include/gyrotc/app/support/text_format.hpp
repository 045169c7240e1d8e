#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

namespace gyrotc::app {

// printf-style formatting into a string as long as the text needs (no fixed
// buffer to truncate a long path or message).
template <typename... Args>
std::string printf_string(const char* format, Args... args) {
  const int length = std::snprintf(nullptr, 0, format, args...);
  if (length <= 0) return {};
  std::string text(static_cast<std::size_t>(length), '\0');
  std::snprintf(text.data(), text.size() + 1, format, args...);
  return text;
}

}  // namespace gyrotc::app
