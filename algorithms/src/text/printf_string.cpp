#include "gyrotc/algorithms/text/printf_string.hpp"

#include <cstdarg>
#include <cstddef>
#include <cstdio>

namespace gyrotc::text {

std::string printf_string(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::va_list again;  // the first pass measures, the second writes
  va_copy(again, args);
  const int length = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::string text;
  if (length > 0) {
    text.resize(static_cast<std::size_t>(length));
    std::vsnprintf(text.data(), text.size() + 1, format, again);
  }
  va_end(again);
  return text;
}

}  // namespace gyrotc::text
