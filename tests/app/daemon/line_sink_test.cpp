#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "gyrotc/app/daemon/line_sink.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using gyrotc::app::LineSink;

namespace {

std::string read_all(int fd) {
  std::string text;
  char buf[4096];
  ssize_t n = 0;
  while ((n = ::read(fd, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(n));
  return text;
}

struct IgnoreSigpipe {
  IgnoreSigpipe() { previous = ::signal(SIGPIPE, SIG_IGN); }
  ~IgnoreSigpipe() { ::signal(SIGPIPE, previous); }
  void (*previous)(int);
};

std::string temp_path(const char* name) { return gyrotc::test::scratch_dir() + "/" + name; }

}  // namespace

TEST_CASE("line sink writes whole lines to a file") {
  const std::string path = temp_path("line_sink_file.txt");
  {
    auto sink = LineSink::open_file(path, false, 0.1);
    CHECK(sink->write_line("time_s,gyro_mv"));
    CHECK(sink->write_line("0.5,2512.25"));
    CHECK(sink->flush());
    CHECK(sink->lines_written() == 2);
  }
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  CHECK(text.str() == "time_s,gyro_mv\n0.5,2512.25\n");
  std::remove(path.c_str());
}

TEST_CASE("line sink on a full disk drops and counts lines and names the error") {
  auto sink = LineSink::open_file("/dev/full", true, 0.1);
  for (int i = 0; i < 10; ++i) CHECK(sink->write_line("1.0,2.0,3.0"));
  CHECK_FALSE(sink->flush());
  CHECK(sink->lines_dropped() == 10);
  CHECK(sink->lines_written() == 0);
  CHECK(sink->first_error().find("No space left on device") != std::string::npos);
  CHECK_FALSE(sink->closed());  // a disk may get space again: later lines are still tried
}

TEST_CASE("line sink to a closed pipe drops every line, without SIGPIPE") {
  IgnoreSigpipe ignore;
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  ::close(fds[0]);
  LineSink sink(fds[1], true, "pipe", 0.1);
  CHECK(sink.write_line("a"));
  CHECK_FALSE(sink.flush());
  CHECK(sink.closed());
  CHECK_FALSE(sink.write_line("b"));
  CHECK(sink.lines_dropped() == 2);
}

TEST_CASE("line sink to a stalled reader gives up after its timeout, keeping lines whole") {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  REQUIRE(::fcntl(fds[0], F_SETFL, O_NONBLOCK) == 0);
  LineSink sink(fds[1], true, "pipe", 0.05);
  const std::string line(99, 'x');  // 100 bytes with the newline
  std::size_t queued = 0;
  const auto start = std::chrono::steady_clock::now();
  // Far more than a pipe holds (64 KiB on Linux): nobody reads.
  for (int i = 0; i < 3000; ++i) {
    if (sink.write_line(line)) ++queued;
  }
  sink.flush();
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  CHECK(elapsed_s < 1.0);  // a few bounded waits, not a hang
  CHECK(sink.lines_dropped() > 0);
  CHECK(sink.lines_written() + sink.lines_dropped() == 3000);
  const std::string got = read_all(fds[0]);
  ::close(fds[0]);
  CHECK(got.size() == sink.lines_written() * 100);
  CHECK(got.size() % 100 == 0);
  CHECK((got.empty() || got.back() == '\n'));
}

TEST_CASE("line sink opens a serial port raw at the configured baud") {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
  REQUIRE(master >= 0);
  REQUIRE(::grantpt(master) == 0);
  REQUIRE(::unlockpt(master) == 0);
  const std::string port = ::ptsname(master);
  {
    auto sink = LineSink::open_serial(port, 115200, 0.1);
    CHECK(sink->write_line("0.001,2500.0"));
    CHECK(sink->flush());
    const int fd = ::open(port.c_str(), O_RDONLY | O_NOCTTY);
    REQUIRE(fd >= 0);
    termios tio{};
    REQUIRE(::tcgetattr(fd, &tio) == 0);
    CHECK(::cfgetospeed(&tio) == B115200);
    CHECK((tio.c_oflag & OPOST) == 0);  // raw: no "\n" -> "\r\n"
    ::close(fd);
  }
  char buf[64] = {};
  const ssize_t n = ::read(master, buf, sizeof buf);
  ::close(master);
  CHECK(std::string(buf, n > 0 ? static_cast<std::size_t>(n) : 0U) == "0.001,2500.0\n");
}

TEST_CASE("line sink rejects a baud rate termios does not have") {
  CHECK_THROWS_AS(LineSink::open_serial("/dev/null", 12345, 0.1), gyrotc::app::InputError);
}

TEST_CASE("line sink names the file it cannot open") {
  try {
    LineSink::open_file("/nonexistent-dir/rec.csv", false, 0.1);
    FAIL("no exception");
  } catch (const gyrotc::app::RuntimeFailure& e) {
    CHECK(std::string(e.what()).find("/nonexistent-dir/rec.csv") != std::string::npos);
  }
}
