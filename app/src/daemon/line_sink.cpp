#include "gyrotc/app/daemon/line_sink.hpp"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/stopwatch.hpp"

namespace gyrotc::app {
namespace {

// A write after POLLOUT of at most this many bytes does not block on a pipe
// or a terminal (so stdout needs no O_NONBLOCK, which would leak to the
// shell sharing the file description).
constexpr std::size_t kChunkBytes = 4096;

std::string errno_text(int errno_value) { return std::strerror(errno_value); }

speed_t baud_constant(int baud) {
  switch (baud) {
    case 1200: return B1200;
    case 2400: return B2400;
    case 4800: return B4800;
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 921600: return B921600;
    default: break;
  }
  throw InputError("output baud " + std::to_string(baud) +
                   " is not a standard rate (1200 ... 921600, e.g. 115200)");
}

}  // namespace

std::unique_ptr<LineSink> LineSink::open_stdout(double write_timeout_s) {
  return std::make_unique<LineSink>(STDOUT_FILENO, false, "stdout", write_timeout_s);
}

std::unique_ptr<LineSink> LineSink::open_file(const std::string& path, bool append, double write_timeout_s) {
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | O_NONBLOCK | (append ? O_APPEND : O_TRUNC);
  const int fd = ::open(path.c_str(), flags, 0644);
  if (fd < 0) throw RuntimeFailure("cannot open output file '" + path + "': " + errno_text(errno));
  return std::make_unique<LineSink>(fd, true, path, write_timeout_s);
}

std::unique_ptr<LineSink> LineSink::open_serial(const std::string& path, int baud, double write_timeout_s) {
  const speed_t speed = baud_constant(baud);
  const int fd = ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw RuntimeFailure("cannot open serial port '" + path + "': " + errno_text(errno));
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) {
    const int err = errno;
    ::close(fd);
    throw RuntimeFailure("'" + path + "' is not a serial port: " + errno_text(err));
  }
  ::cfmakeraw(&tio);  // 8 data bits, no parity, no echo, no output processing
  tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS);
  tio.c_cflag |= CLOCAL;
  if (::cfsetospeed(&tio, speed) != 0 || ::cfsetispeed(&tio, speed) != 0 ||
      ::tcsetattr(fd, TCSANOW, &tio) != 0) {
    const int err = errno;
    ::close(fd);
    throw RuntimeFailure("cannot set '" + path + "' to " + std::to_string(baud) + " baud: " + errno_text(err));
  }
  return std::make_unique<LineSink>(fd, true, path, write_timeout_s);
}

LineSink::LineSink(int fd, bool owned, std::string name, double write_timeout_s)
    : fd_(fd), owned_(owned), name_(std::move(name)), write_timeout_s_(write_timeout_s) {
  buffer_.reserve(kBufferBytes);
}

LineSink::~LineSink() {
  flush();
  if (owned_) ::close(fd_);
}

bool LineSink::write_line(std::string_view line) noexcept {
  const std::size_t needed = line.size() + 1;
  if (closed_ || needed > kBufferBytes) {
    ++lines_dropped_;
    return false;
  }
  if (buffer_.size() + needed > kBufferBytes) flush();
  if (buffer_.size() + needed > kBufferBytes) {
    ++lines_dropped_;
    return false;
  }
  buffer_.insert(buffer_.end(), line.begin(), line.end());  // within the reserved capacity
  buffer_.push_back('\n');
  return true;
}

bool LineSink::flush() noexcept {
  auto start = std::chrono::steady_clock::now();
  bool finishing_line = false;  // the wait ran out in the middle of a line
  std::size_t done = 0;
  std::size_t lines_done = 0;
  bool ok = true;
  while (done < buffer_.size()) {
    const double left_s = write_timeout_s_ - seconds_since(start);
    pollfd pfd{fd_, POLLOUT, 0};
    const int timeout_ms = left_s > 0.0 ? static_cast<int>(left_s * 1000.0) + 1 : 0;
    const int ready = ::poll(&pfd, 1, timeout_ms);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      // The reader is not keeping up: drop every line not begun. A line
      // begun gets one more wait to end, so the reader sees whole lines.
      ok = false;
      const bool at_line_start = done == 0 || buffer_[done - 1] == '\n';
      if (at_line_start || finishing_line) {
        drop_queued(done);
        break;
      }
      const auto newline = std::find(buffer_.begin() + static_cast<std::ptrdiff_t>(done), buffer_.end(), '\n');
      drop_queued(static_cast<std::size_t>(newline - buffer_.begin()) + 1);
      finishing_line = true;
      start = std::chrono::steady_clock::now();
      continue;
    }
    if ((pfd.revents & POLLOUT) == 0) {  // POLLERR / POLLHUP / POLLNVAL only
      note_error((pfd.revents & POLLNVAL) != 0 ? EBADF : EPIPE);
      drop_queued(done);
      ok = false;
      break;
    }
    const std::size_t chunk = std::min(kChunkBytes, buffer_.size() - done);
    const ssize_t n = ::write(fd_, buffer_.data() + done, chunk);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      note_error(errno);
      drop_queued(done);
      ok = false;
      break;
    }
    const auto first = buffer_.begin() + static_cast<std::ptrdiff_t>(done);
    lines_done += static_cast<std::size_t>(std::count(first, first + n, '\n'));
    done += static_cast<std::size_t>(n);
  }
  lines_written_ += lines_done;
  buffer_.clear();  // written or dropped
  return ok;
}

void LineSink::drop_queued(std::size_t from) noexcept {
  if (from >= buffer_.size()) return;
  lines_dropped_ += static_cast<std::uint64_t>(
      std::count(buffer_.begin() + static_cast<std::ptrdiff_t>(from), buffer_.end(), '\n'));
  buffer_.resize(from);
}

void LineSink::note_error(int errno_value) noexcept {
  if (errno_value == EPIPE) closed_ = true;
  if (!first_error_.empty()) return;
  try {
    first_error_ = "'" + name_ + "': " + errno_text(errno_value);
  } catch (...) {  // out of memory while describing an error: keep the counts only
  }
}

}  // namespace gyrotc::app
