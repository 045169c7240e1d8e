#pragma once

#include <cstdio>
#include <mutex>
#include <string>
#include <string_view>

// What the emulated board saw, one CSV line per event, for a person reading
// it and for `gyrotc-emu report` (hil_report.hpp):
//
//   t_s,kind,device,value,detail
//   1234.567891,dac,tec_dac,32768,mode=normal;pid=812   every DAC frame the part latched,
//                                             and the process that wrote it
//   1234.568012,es,drive,0,                   E/S as the OPA548 sees it (1 = enabled)
//   1234.600000,plant,casing_c,54.9981,die_c=..;sensor_c=..;ambient_c=..;tec_a=..;enabled=1
//   1234.700000,fault,casing_sensor,disconnect,
//
// t_s is CLOCK_MONOTONIC, the clock of the daemon's edge stamps and of the
// journal's monotonic timestamps (journalctl -o short-monotonic), so the two
// can be laid side by side. Any thread; lines are written whole and flushed
// at least every flush_interval lines and on flush().
namespace gyrotc::emu {

class EventLog {
 public:
  // "" or "-": no file (events are only counted); otherwise the file is
  // created (truncated). Throws app::RuntimeFailure naming the file.
  explicit EventLog(const std::string& path);
  ~EventLog();
  EventLog(const EventLog&) = delete;
  EventLog& operator=(const EventLog&) = delete;

  void add(double t_s, std::string_view kind, std::string_view device, std::string_view value,
           std::string_view detail = {});
  void flush();
  std::size_t lines() const;
  const std::string& path() const noexcept { return path_; }

  static constexpr const char* kHeader = "t_s,kind,device,value,detail";

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  mutable std::mutex mutex_;
  std::size_t lines_ = 0;
  std::size_t unflushed_ = 0;
};

}  // namespace gyrotc::emu
