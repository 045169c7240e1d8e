// GpiodLine on the libgpiod 1.6 API (Debian 12; Yocto with
// PREFERRED_VERSION_libgpiod = "1.6%"). Built instead of gpiod_line_v2.cpp
// when configure finds libgpiod 1.x.
#include <gpiod.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <ctime>

#include "gyrotc/hal/linux/gpiod_line.hpp"

namespace gyrotc::hal {

struct GpiodLine::Handles {
  gpiod_chip* chip = nullptr;
  gpiod_line* line = nullptr;
  ~Handles() {
    if (chip != nullptr) gpiod_chip_close(chip);  // releases the line
  }
};

namespace {

int errno_or(int fallback) noexcept { return errno != 0 ? errno : fallback; }

int request_flags(const GpiodLineSpec& spec) noexcept {
  int flags = spec.active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  switch (spec.bias) {
    case GpioBias::as_is: break;
    case GpioBias::disabled: flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE; break;
    case GpioBias::pull_up: flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP; break;
    case GpioBias::pull_down: flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN; break;
  }
  if (spec.mode == GpioMode::output && spec.open_drain) flags |= GPIOD_LINE_REQUEST_FLAG_OPEN_DRAIN;
  return flags;
}

}  // namespace

GpiodLine::GpiodLine(std::string name, const GpiodLineSpec& spec, std::unique_ptr<Handles> handles) noexcept
    : name_(std::move(name)), mode_(spec.mode), edge_(spec.edge), handles_(std::move(handles)) {}

GpiodLine::~GpiodLine() = default;

std::string GpiodLine::library_version() { return std::string("libgpiod ") + gpiod_version_string(); }

Result<std::unique_ptr<GpiodLine>> GpiodLine::open(const GpiodLineSpec& spec) noexcept {
  const std::string name = spec.chip + ":" + spec.line;
  auto handles = std::make_unique<Handles>();
  errno = 0;
  handles->chip = gpiod_chip_open_lookup(spec.chip.c_str());
  if (handles->chip == nullptr) return Error::from_errno(errno_or(ENOENT), "cannot open gpiochip", spec.chip);

  unsigned offset = 0;
  const char* end = spec.line.data() + spec.line.size();
  const auto [ptr, ec] = std::from_chars(spec.line.data(), end, offset);
  errno = 0;
  handles->line = (!spec.line.empty() && ec == std::errc{} && ptr == end)
                      ? gpiod_chip_get_line(handles->chip, offset)
                      : gpiod_chip_find_line(handles->chip, spec.line.c_str());
  if (handles->line == nullptr) return Error::from_errno(errno_or(ENOENT), "no GPIO line", name);

  const int flags = request_flags(spec);
  int rc = -1;
  errno = 0;
  switch (spec.mode) {
    case GpioMode::output:
      rc = gpiod_line_request_output_flags(handles->line, kConsumer, flags, spec.initial_high ? 1 : 0);
      break;
    case GpioMode::input: rc = gpiod_line_request_input_flags(handles->line, kConsumer, flags); break;
    case GpioMode::edge_events:
      rc = spec.edge == Edge::falling
               ? gpiod_line_request_falling_edge_events_flags(handles->line, kConsumer, flags)
               : gpiod_line_request_rising_edge_events_flags(handles->line, kConsumer, flags);
      break;
  }
  if (rc < 0) return Error::from_errno(errno_or(EIO), "cannot request GPIO line", name);
  return std::unique_ptr<GpiodLine>(new GpiodLine(name, spec, std::move(handles)));
}

Status GpiodLine::do_set(bool high) noexcept {
  if (Status s = check_settable(); !s) return s;
  if (gpiod_line_set_value(handles_->line, high ? 1 : 0) < 0) return Error::from_errno(errno, "cannot set GPIO", name_);
  return {};
}

Result<bool> GpiodLine::do_get() noexcept {
  const int value = gpiod_line_get_value(handles_->line);
  if (value < 0) return Error::from_errno(errno, "cannot read GPIO", name_);
  return value != 0;
}

Result<double> GpiodLine::do_wait_edge(Edge edge, double timeout_s) noexcept {
  if (Status s = check_edge(edge); !s) return s.error();
  const double left_s = std::max(0.0, timeout_s);
  timespec timeout{};
  timeout.tv_sec = static_cast<time_t>(left_s);
  timeout.tv_nsec = static_cast<long>((left_s - std::floor(left_s)) * 1e9);
  const int rc = gpiod_line_event_wait(handles_->line, &timeout);
  if (rc < 0) return Error::from_errno(errno, "cannot wait for an edge on GPIO", name_);
  if (rc == 0) {
    return Error::make(ErrorCode::timeout, "no %s edge on GPIO '%s' within %.3f s",
                       edge == Edge::rising ? "rising" : "falling", name_.c_str(), timeout_s);
  }
  // Only the requested edge is queued (one-edge request), so the oldest
  // event is the answer.
  gpiod_line_event event{};
  if (gpiod_line_event_read(handles_->line, &event) < 0) {
    return Error::from_errno(errno, "cannot read an edge of GPIO", name_);
  }
  // The uAPI v1 that libgpiod 1.6 uses stamps events with CLOCK_MONOTONIC
  // since Linux 5.7 (Debian 12 runs 6.1). The stamp is kept as it is even
  // when old: a queued edge is older than the wait that returns it.
  return static_cast<double>(event.ts.tv_sec) + static_cast<double>(event.ts.tv_nsec) * 1e-9;
}

Result<int> GpiodLine::do_discard_edges() noexcept {
  if (mode_ != GpioMode::edge_events) return 0;
  int dropped = 0;
  for (;;) {
    timespec zero{};
    const int rc = gpiod_line_event_wait(handles_->line, &zero);
    if (rc < 0) return Error::from_errno(errno, "cannot poll the edges of GPIO", name_);
    if (rc == 0) return dropped;
    gpiod_line_event events[16];
    const int got = gpiod_line_event_read_multiple(handles_->line, events, 16);
    if (got < 0) return Error::from_errno(errno, "cannot read the edges of GPIO", name_);
    dropped += got;
  }
}

}  // namespace gyrotc::hal
