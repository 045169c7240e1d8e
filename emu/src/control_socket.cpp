#include "gyrotc/emu/control_socket.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::emu {

namespace {

sockaddr_un address_of(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  if (path.size() >= sizeof a.sun_path) throw app::InputError("control socket path too long: '" + path + "'");
  std::memcpy(a.sun_path, path.c_str(), path.size() + 1);
  return a;
}

// One line (without its newline) from fd, waiting at most timeout_ms in all.
bool read_line(int fd, std::string& line, int timeout_ms) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  char c = 0;
  while (line.size() < 4096) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
    const ssize_t n = ::read(fd, &c, 1);
    if (n <= 0) return !line.empty();
    if (c == '\n') return true;
    line.push_back(c);
  }
  return true;
}

void write_all(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace

ControlServer::ControlServer(std::string path, Handler handler) : path_(std::move(path)), handler_(std::move(handler)) {
  const sockaddr_un a = address_of(path_);
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw app::RuntimeFailure(std::string("cannot create the control socket: ") + std::strerror(errno));
  ::unlink(path_.c_str());
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 8) != 0 ||
      ::pipe2(wake_, O_CLOEXEC) != 0) {
    const int e = errno;
    ::close(fd_);
    throw app::RuntimeFailure("cannot listen on '" + path_ + "': " + std::strerror(e));
  }
  ::chmod(path_.c_str(), 0660);
  thread_ = std::thread([this] { serve(); });
}

ControlServer::~ControlServer() {
  if (wake_[1] >= 0) (void)::write(wake_[1], "x", 1);
  if (thread_.joinable()) thread_.join();
  ::close(fd_);
  ::close(wake_[0]);
  ::close(wake_[1]);
  ::unlink(path_.c_str());
}

void ControlServer::serve() {
  for (;;) {
    pollfd p[2] = {{fd_, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    if (::poll(p, 2, -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if ((p[1].revents & POLLIN) != 0) return;
    if ((p[0].revents & POLLIN) == 0) continue;
    const int client = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) continue;
    std::string line;
    if (read_line(client, line, 2000)) {
      std::string reply;
      try {
        reply = handler_(line);
      } catch (const std::exception& e) {
        reply = std::string("error: ") + e.what();
      }
      write_all(client, reply + "\n");
    }
    ::close(client);
  }
}

std::string control_request(const std::string& path, const std::string& command, double timeout_s) {
  const sockaddr_un a = address_of(path);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw app::RuntimeFailure(std::string("cannot create a socket: ") + std::strerror(errno));
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    const int e = errno;
    ::close(fd);
    throw app::RuntimeFailure("no gyrotc-emu listens on '" + path + "' (" + std::strerror(e) +
                              "): is `gyrotc-emu run` running with this --control socket?");
  }
  write_all(fd, command + "\n");
  std::string line;
  const bool ok = read_line(fd, line, static_cast<int>(timeout_s * 1000.0));
  ::close(fd);
  if (!ok) throw app::RuntimeFailure("gyrotc-emu on '" + path + "' did not answer within the timeout");
  return line;
}

}  // namespace gyrotc::emu
