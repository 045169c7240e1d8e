#pragma once

namespace gyrotc::app::log {

// The daemon's log on stderr. Under systemd (JOURNAL_STREAM set) each line
// starts with its journald priority ("<3>" error ... "<7>" debug, see
// sd-daemon(3)); on a terminal it reads "gyrotc: warning: ...". Never called
// from the real-time thread.
enum class Level { error = 3, warning = 4, notice = 5, info = 6, debug = 7 };

[[gnu::format(printf, 2, 3)]] void write(Level level, const char* format, ...) noexcept;

}  // namespace gyrotc::app::log

#define GYROTC_LOG_ERROR(...) ::gyrotc::app::log::write(::gyrotc::app::log::Level::error, __VA_ARGS__)
#define GYROTC_LOG_WARNING(...) ::gyrotc::app::log::write(::gyrotc::app::log::Level::warning, __VA_ARGS__)
#define GYROTC_LOG_NOTICE(...) ::gyrotc::app::log::write(::gyrotc::app::log::Level::notice, __VA_ARGS__)
#define GYROTC_LOG_INFO(...) ::gyrotc::app::log::write(::gyrotc::app::log::Level::info, __VA_ARGS__)
