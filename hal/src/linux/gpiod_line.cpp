#include "gyrotc/hal/linux/gpiod_line.hpp"

#include <gpiod.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <ctime>

namespace gyrotc::hal {

namespace {

double monotonic_now_s() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

int errno_or(int fallback) noexcept { return errno != 0 ? errno : fallback; }

}  // namespace

Result<std::unique_ptr<GpiodLine>> GpiodLine::open(const GpiodLineSpec& spec) noexcept {
  const std::string name = spec.chip + ":" + spec.line;
  errno = 0;
  gpiod_chip* chip = gpiod_chip_open_lookup(spec.chip.c_str());
  if (chip == nullptr) return Error::from_errno(errno_or(ENOENT), "cannot open gpiochip", spec.chip);

  unsigned offset = 0;
  const char* end = spec.line.data() + spec.line.size();
  const auto [ptr, ec] = std::from_chars(spec.line.data(), end, offset);
  errno = 0;
  gpiod_line* line = (!spec.line.empty() && ec == std::errc{} && ptr == end)
                         ? gpiod_chip_get_line(chip, offset)
                         : gpiod_chip_find_line(chip, spec.line.c_str());
  if (line == nullptr) {
    const Error e = Error::from_errno(errno_or(ENOENT), "no GPIO line", name);
    gpiod_chip_close(chip);
    return e;
  }

  int rc = -1;
  errno = 0;
  switch (spec.mode) {
    case GpioMode::output:
      rc = gpiod_line_request_output_flags(line, kConsumer,
                                           spec.open_drain ? GPIOD_LINE_REQUEST_FLAG_OPEN_DRAIN : 0,
                                           spec.initial_high ? 1 : 0);
      break;
    case GpioMode::input: rc = gpiod_line_request_input(line, kConsumer); break;
    case GpioMode::edge_events: rc = gpiod_line_request_both_edges_events(line, kConsumer); break;
  }
  if (rc < 0) {
    const Error e = Error::from_errno(errno_or(EIO), "cannot request GPIO line", name);
    gpiod_chip_close(chip);
    return e;
  }
  return std::unique_ptr<GpiodLine>(new GpiodLine(name, spec.mode, chip, line));
}

GpiodLine::~GpiodLine() { gpiod_chip_close(chip_); }  // releases the line

Status GpiodLine::do_set(bool high) noexcept {
  if (mode_ != GpioMode::output) {
    return Error::make(ErrorCode::invalid_config, "GPIO '%s' is not an output", name_.c_str());
  }
  if (gpiod_line_set_value(line_, high ? 1 : 0) < 0) return Error::from_errno(errno, "cannot set GPIO", name_);
  return {};
}

Result<bool> GpiodLine::do_get() noexcept {
  const int value = gpiod_line_get_value(line_);
  if (value < 0) return Error::from_errno(errno, "cannot read GPIO", name_);
  return value != 0;
}

Result<double> GpiodLine::do_wait_edge(Edge edge, double timeout_s) noexcept {
  if (mode_ != GpioMode::edge_events) {
    return Error::make(ErrorCode::invalid_config, "GPIO '%s' was not requested for edge events", name_.c_str());
  }
  const double deadline_s = monotonic_now_s() + timeout_s;
  const int wanted = edge == Edge::rising ? GPIOD_LINE_EVENT_RISING_EDGE : GPIOD_LINE_EVENT_FALLING_EDGE;
  for (;;) {
    const double left_s = std::max(0.0, deadline_s - monotonic_now_s());
    timespec timeout{};
    timeout.tv_sec = static_cast<time_t>(left_s);
    timeout.tv_nsec = static_cast<long>((left_s - std::floor(left_s)) * 1e9);
    const int rc = gpiod_line_event_wait(line_, &timeout);
    if (rc < 0) return Error::from_errno(errno, "cannot wait for an edge on GPIO", name_);
    if (rc == 0) {
      return Error::make(ErrorCode::timeout, "no %s edge on GPIO '%s' within %.3f s",
                         edge == Edge::rising ? "rising" : "falling", name_.c_str(), timeout_s);
    }
    gpiod_line_event event{};
    if (gpiod_line_event_read(line_, &event) < 0) return Error::from_errno(errno, "cannot read an edge of GPIO", name_);
    if (event.event_type != wanted) continue;
    // Kernels >= 5.7 stamp line events with CLOCK_MONOTONIC; older ones used
    // the real-time clock, recognised by being far from monotonic now.
    const double now_s = monotonic_now_s();
    const double stamp_s = static_cast<double>(event.ts.tv_sec) + static_cast<double>(event.ts.tv_nsec) * 1e-9;
    return std::abs(now_s - stamp_s) < 1.0 ? stamp_s : now_s;
  }
}

Result<int> GpiodLine::do_discard_edges() noexcept {
  if (mode_ != GpioMode::edge_events) return 0;
  int dropped = 0;
  for (;;) {
    timespec zero{};
    const int rc = gpiod_line_event_wait(line_, &zero);
    if (rc < 0) return Error::from_errno(errno, "cannot poll the edges of GPIO", name_);
    if (rc == 0) return dropped;
    gpiod_line_event events[16];
    const int got = gpiod_line_event_read_multiple(line_, events, 16);
    if (got < 0) return Error::from_errno(errno, "cannot read the edges of GPIO", name_);
    dropped += got;
  }
}

}  // namespace gyrotc::hal
