#include "gyrotc/emu/event_log.hpp"

#include <cerrno>
#include <cstring>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::emu {

namespace {
constexpr std::size_t kFlushLines = 256;
}

EventLog::EventLog(const std::string& path) : path_(path == "-" ? "" : path) {
  if (path_.empty()) return;
  file_ = std::fopen(path_.c_str(), "we");
  if (file_ == nullptr) {
    throw app::RuntimeFailure("cannot create the event log '" + path_ + "': " + std::strerror(errno));
  }
  std::fprintf(file_, "%s\n", kHeader);
  std::fflush(file_);
}

EventLog::~EventLog() {
  if (file_ != nullptr) std::fclose(file_);
}

void EventLog::add(double t_s, std::string_view kind, std::string_view device, std::string_view value,
                   std::string_view detail) {
  const std::lock_guard lock(mutex_);
  ++lines_;
  if (file_ == nullptr) return;
  std::fprintf(file_, "%.6f,%.*s,%.*s,%.*s,%.*s\n", t_s, static_cast<int>(kind.size()), kind.data(),
               static_cast<int>(device.size()), device.data(), static_cast<int>(value.size()), value.data(),
               static_cast<int>(detail.size()), detail.data());
  if (++unflushed_ >= kFlushLines) {
    std::fflush(file_);
    unflushed_ = 0;
  }
}

void EventLog::flush() {
  const std::lock_guard lock(mutex_);
  if (file_ != nullptr) std::fflush(file_);
  unflushed_ = 0;
}

std::size_t EventLog::lines() const {
  const std::lock_guard lock(mutex_);
  return lines_;
}

}  // namespace gyrotc::emu
