#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace gyrotc::app {

// Where text lines go: stdout, a file, a serial port. Used by the output
// thread only (never the real-time one). Lines are buffered and written with
// a bounded wait: a reader that stalls (a paused pager, a slow UART) or a
// write that fails (a full disk, a closed pipe) makes lines be dropped and
// counted, never makes the writer wait longer than write_timeout_s. The
// stream stays line-aligned: a line is written whole or not at all.
class LineSink {
 public:
  static constexpr std::size_t kBufferBytes = 64 * 1024;

  // stdout (not closed on destruction).
  static std::unique_ptr<LineSink> open_stdout(double write_timeout_s);
  // A regular file, truncated unless `append`. Throws RuntimeFailure naming
  // the path and the errno text.
  static std::unique_ptr<LineSink> open_file(const std::string& path, bool append, double write_timeout_s);
  // A serial port in raw 8N1 at `baud`. Throws InputError for a baud rate
  // termios does not know, RuntimeFailure for a device that fails.
  static std::unique_ptr<LineSink> open_serial(const std::string& path, int baud, double write_timeout_s);
  // An already open descriptor (tests); closed on destruction if `owned`.
  LineSink(int fd, bool owned, std::string name, double write_timeout_s);

  ~LineSink();
  LineSink(const LineSink&) = delete;
  LineSink& operator=(const LineSink&) = delete;

  // Queues one line (`line` without the newline). False if it was dropped.
  bool write_line(std::string_view line) noexcept;
  // Writes what is queued, waiting at most write_timeout_s for the reader.
  // False if anything was dropped.
  bool flush() noexcept;

  const std::string& name() const noexcept { return name_; }
  std::uint64_t lines_written() const noexcept { return lines_written_; }
  std::uint64_t lines_dropped() const noexcept { return lines_dropped_; }
  // The first write error (empty if none), e.g. "'/data/rec.csv': No space left on device".
  const std::string& first_error() const noexcept { return first_error_; }
  // The reader has gone (EPIPE): every further line is dropped.
  bool closed() const noexcept { return closed_; }

 private:
  void drop_queued(std::size_t from) noexcept;
  void note_error(int errno_value) noexcept;

  int fd_;
  bool owned_;
  std::string name_;
  double write_timeout_s_;
  std::vector<char> buffer_;  // capacity kBufferBytes, reserved once
  std::uint64_t lines_written_ = 0;
  std::uint64_t lines_dropped_ = 0;
  std::string first_error_;
  bool closed_ = false;
};

}  // namespace gyrotc::app
