#include "gyrotc/app/daemon/systemd_notify.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace gyrotc::app {

#if GYROTC_SYSTEMD_NOTIFY
namespace {

// $WATCHDOG_USEC in seconds, if the watchdog is meant for this process.
std::optional<double> watchdog_from_environment() {
  const char* usec_text = std::getenv("WATCHDOG_USEC");
  if (usec_text == nullptr) return std::nullopt;
  if (const char* pid_text = std::getenv("WATCHDOG_PID")) {
    char* end = nullptr;
    const long pid = std::strtol(pid_text, &end, 10);
    if (end == pid_text || *end != '\0' || pid != static_cast<long>(::getpid())) return std::nullopt;
  }
  char* end = nullptr;
  const unsigned long long usec = std::strtoull(usec_text, &end, 10);
  if (end == usec_text || *end != '\0' || usec == 0) return std::nullopt;
  return static_cast<double>(usec) * 1e-6;
}

}  // namespace
#endif

SystemdNotify::SystemdNotify() noexcept {
#if GYROTC_SYSTEMD_NOTIFY
  const char* path = std::getenv("NOTIFY_SOCKET");
  if (path == nullptr) return;
  const std::size_t len = std::strlen(path);
  // An absolute path or '@abstract'; anything else (empty, relative, too long
  // for sun_path, or systemd's newer vsock: addresses) is not ours to reach.
  if (len < 2 || (path[0] != '/' && path[0] != '@') || len > sizeof address_.sun_path) return;
  address_.sun_family = AF_UNIX;
  std::memcpy(address_.sun_path, path, len);
  if (path[0] == '@') address_.sun_path[0] = '\0';
  address_len_ = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + len);
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) return;
  watchdog_s_ = watchdog_from_environment();
#endif
}

SystemdNotify::~SystemdNotify() {
  if (fd_ >= 0) ::close(fd_);
}

void SystemdNotify::ready() noexcept { send("READY=1"); }
void SystemdNotify::watchdog() noexcept { send("WATCHDOG=1"); }
void SystemdNotify::stopping() noexcept { send("STOPPING=1"); }

void SystemdNotify::status(std::string_view text) noexcept {
  char message[256];
  const int n = std::snprintf(message, sizeof message, "STATUS=%.*s", static_cast<int>(text.size()), text.data());
  if (n > 0) send({message, std::min(static_cast<std::size_t>(n), sizeof message - 1)});
}

// Best effort, as sd_notify: a lost notification must not stop the daemon
// (systemd's watchdog is what notices a daemon that stopped pinging).
void SystemdNotify::send(std::string_view message) noexcept {
  if (fd_ < 0) return;
  (void)::sendto(fd_, message.data(), message.size(), MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&address_),
                 address_len_);
}

}  // namespace gyrotc::app
