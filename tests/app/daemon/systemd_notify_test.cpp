// The sd_notify protocol as systemd's side sees it: a datagram socket at
// $NOTIFY_SOCKET receiving READY=1, WATCHDOG=1, STATUS=..., STOPPING=1.

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

#include "gyrotc/app/daemon/systemd_notify.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::SystemdNotify;

namespace {

// systemd's end of the notify socket, and the environment a unit gives its main process.
class FakeSystemd {
 public:
  FakeSystemd() {
    path_ = (std::filesystem::temp_directory_path() / ("gyrotc_notify_" + std::to_string(::getpid()))).string();
    std::filesystem::remove(path_);
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path_.c_str(), sizeof address.sun_path - 1);
    REQUIRE(::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0);
    timeval timeout{1, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    ::setenv("NOTIFY_SOCKET", path_.c_str(), 1);
  }
  ~FakeSystemd() {
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
    ::close(fd_);
    std::filesystem::remove(path_);
  }
  FakeSystemd(const FakeSystemd&) = delete;
  FakeSystemd& operator=(const FakeSystemd&) = delete;

  // The next datagram, or "" after a second without one.
  std::string receive() const {
    char buffer[512];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
  }

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace

TEST_CASE("under systemd the daemon sends READY, WATCHDOG, STATUS and STOPPING to the notify socket") {
  FakeSystemd systemd;
  SystemdNotify notify;
  REQUIRE(notify.enabled());
  notify.ready();
  notify.watchdog();
  notify.status("loop 20000 samples/s");
  notify.stopping();
  CHECK(systemd.receive() == "READY=1");
  CHECK(systemd.receive() == "WATCHDOG=1");
  CHECK(systemd.receive() == "STATUS=loop 20000 samples/s");
  CHECK(systemd.receive() == "STOPPING=1");
}

TEST_CASE("the watchdog interval is WATCHDOG_USEC when WATCHDOG_PID names this process") {
  FakeSystemd systemd;
  ::setenv("WATCHDOG_USEC", "5000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
  const SystemdNotify notify;
  REQUIRE(notify.watchdog_interval_s().has_value());
  CHECK(*notify.watchdog_interval_s() == Approx(5.0));
}

TEST_CASE("a watchdog meant for another process is not taken") {
  FakeSystemd systemd;
  ::setenv("WATCHDOG_USEC", "5000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid() + 1).c_str(), 1);
  CHECK_FALSE(SystemdNotify().watchdog_interval_s().has_value());
}

TEST_CASE("outside systemd every notification is a no-op") {
  ::unsetenv("NOTIFY_SOCKET");
  SystemdNotify notify;
  CHECK_FALSE(notify.enabled());
  CHECK_FALSE(notify.watchdog_interval_s().has_value());
  notify.ready();
  notify.stopping();
}

TEST_CASE("a relative NOTIFY_SOCKET is ignored rather than guessed at") {
  ::setenv("NOTIFY_SOCKET", "notify", 1);
  CHECK_FALSE(SystemdNotify().enabled());
  ::unsetenv("NOTIFY_SOCKET");
}
