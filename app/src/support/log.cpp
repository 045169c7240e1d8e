#include "gyrotc/app/support/log.hpp"

#include <cstdarg>
#include <cstdio>
#include <cstdlib>

namespace gyrotc::app::log {
namespace {

const char* level_name(Level level) noexcept {
  switch (level) {
    case Level::error: return "error";
    case Level::warning: return "warning";
    case Level::notice: return "notice";
    case Level::info: return "info";
    case Level::debug: return "debug";
  }
  return "info";
}

}  // namespace

void write(Level level, const char* format, ...) noexcept {
  // One fixed buffer and one fputs per line, so lines of different threads
  // do not interleave (stdio locks the stream per call).
  char line[1024];
  const bool journal = std::getenv("JOURNAL_STREAM") != nullptr;
  const int prefix = journal ? std::snprintf(line, sizeof line, "<%d>", static_cast<int>(level))
                             : std::snprintf(line, sizeof line, "gyrotc: %s: ", level_name(level));
  std::va_list args;
  va_start(args, format);
  const auto used = static_cast<std::size_t>(prefix);
  const int body = std::vsnprintf(line + used, sizeof line - used, format, args);
  va_end(args);
  std::size_t end = used + (body > 0 ? static_cast<std::size_t>(body) : 0U);
  if (end > sizeof line - 2) end = sizeof line - 2;
  line[end] = '\n';
  line[end + 1] = '\0';
  std::fputs(line, stderr);
  std::fflush(stderr);
}

}  // namespace gyrotc::app::log
