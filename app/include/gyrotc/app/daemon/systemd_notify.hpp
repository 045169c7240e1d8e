#pragma once

#include <sys/socket.h>
#include <sys/un.h>

#include <optional>
#include <string_view>

namespace gyrotc::app {

// Type=notify support: READY=1 once the loop runs, WATCHDOG=1 pings while it
// keeps running, STOPPING=1 on the way out. Speaks the sd_notify protocol
// itself (one datagram per message to the AF_UNIX socket in $NOTIFY_SOCKET,
// a leading '@' meaning the abstract namespace; see sd_notify(3), which
// documents it as a stable interface), so no build needs libsystemd: a
// cross-built package works under systemd as the native one does. Outside
// systemd (no NOTIFY_SOCKET), or built with GYROTC_SYSTEMD_NOTIFY=OFF, every
// call does nothing and enabled() is false.
class SystemdNotify {
 public:
  SystemdNotify() noexcept;
  ~SystemdNotify();
  SystemdNotify(const SystemdNotify&) = delete;
  SystemdNotify& operator=(const SystemdNotify&) = delete;

  // Started by systemd with a notify socket that could be addressed.
  bool enabled() const noexcept { return fd_ >= 0; }
  // WatchdogSec of the unit ($WATCHDOG_USEC, for this process when
  // $WATCHDOG_PID is set), if the watchdog is on: ping at least twice as often.
  std::optional<double> watchdog_interval_s() const noexcept { return watchdog_s_; }

  void ready() noexcept;
  void watchdog() noexcept;
  void stopping() noexcept;
  // STATUS=<text> (shown by systemctl status).
  void status(std::string_view text) noexcept;

 private:
  void send(std::string_view message) noexcept;

  int fd_ = -1;
  sockaddr_un address_{};
  socklen_t address_len_ = 0;
  std::optional<double> watchdog_s_;
};

}  // namespace gyrotc::app
