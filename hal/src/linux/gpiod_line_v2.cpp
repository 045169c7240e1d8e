// GpiodLine on the libgpiod 2.x API (Debian 13 / Raspberry Pi OS, Yocto
// scarthgap and later): one gpiod_line_request per line. Built instead of
// gpiod_line_v1.cpp when configure finds libgpiod 2.x.
#include <dirent.h>
#include <gpiod.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "gyrotc/hal/linux/gpiod_line.hpp"

namespace gyrotc::hal {

struct GpiodLine::Handles {
  gpiod_chip* chip = nullptr;
  gpiod_line_request* request = nullptr;
  gpiod_edge_event_buffer* events = nullptr;  // allocated once: reads on the loop do not allocate
  unsigned offset = 0;
  ~Handles() {
    if (events != nullptr) gpiod_edge_event_buffer_free(events);
    if (request != nullptr) gpiod_line_request_release(request);
    if (chip != nullptr) gpiod_chip_close(chip);
  }
};

namespace {

constexpr std::size_t kEventBatch = 16;

int errno_or(int fallback) noexcept { return errno != 0 ? errno : fallback; }

bool parse_unsigned(std::string_view text, unsigned& value) noexcept {
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  return !text.empty() && ec == std::errc{} && ptr == end;
}

// libgpiod 2 opens chips by path only; 1.6's gpiod_chip_open_lookup also took
// a name, a number or a label, and configurations written for it keep working.
gpiod_chip* open_chip(const std::string& chip) noexcept {
  if (chip.find('/') != std::string::npos) return gpiod_chip_open(chip.c_str());
  unsigned number = 0;
  const std::string path = parse_unsigned(chip, number) ? "/dev/gpiochip" + chip : "/dev/" + chip;
  if (gpiod_is_gpiochip_device(path.c_str())) return gpiod_chip_open(path.c_str());
  // A label ("pinctrl-bcm2711"): the chip under /dev that carries it. A chip
  // that cannot be opened might be it: not found then reports why it could
  // not be opened (EACCES: udev has not given the node to the group yet), as
  // libgpiod 1.6's lookup does.
  DIR* dev = opendir("/dev");
  if (dev == nullptr) return nullptr;
  gpiod_chip* found = nullptr;
  int unopened_errno = 0;
  while (const dirent* entry = readdir(dev)) {
    if (std::strncmp(entry->d_name, "gpiochip", 8) != 0) continue;
    const std::string candidate = std::string("/dev/") + entry->d_name;
    if (!gpiod_is_gpiochip_device(candidate.c_str())) continue;
    gpiod_chip* c = gpiod_chip_open(candidate.c_str());
    if (c == nullptr) {
      unopened_errno = errno;
      continue;
    }
    gpiod_chip_info* info = gpiod_chip_get_info(c);
    const bool match = info != nullptr && chip == gpiod_chip_info_get_label(info);
    if (info != nullptr) gpiod_chip_info_free(info);
    if (match) {
      found = c;
      break;
    }
    gpiod_chip_close(c);
  }
  closedir(dev);
  if (found == nullptr) errno = unopened_errno != 0 ? unopened_errno : ENOENT;
  return found;
}

gpiod_line_bias to_bias(GpioBias bias) noexcept {
  switch (bias) {
    case GpioBias::disabled: return GPIOD_LINE_BIAS_DISABLED;
    case GpioBias::pull_up: return GPIOD_LINE_BIAS_PULL_UP;
    case GpioBias::pull_down: return GPIOD_LINE_BIAS_PULL_DOWN;
    case GpioBias::as_is: break;
  }
  return GPIOD_LINE_BIAS_AS_IS;
}

// The settings of one line, or null with errno set.
gpiod_line_settings* make_settings(const GpiodLineSpec& spec) noexcept {
  gpiod_line_settings* s = gpiod_line_settings_new();
  if (s == nullptr) return nullptr;
  gpiod_line_settings_set_active_low(s, spec.active_low);
  int rc = gpiod_line_settings_set_bias(s, to_bias(spec.bias));
  switch (spec.mode) {
    case GpioMode::output:
      rc |= gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_OUTPUT);
      rc |= gpiod_line_settings_set_drive(s, spec.open_drain ? GPIOD_LINE_DRIVE_OPEN_DRAIN : GPIOD_LINE_DRIVE_PUSH_PULL);
      rc |= gpiod_line_settings_set_output_value(
          s, spec.initial_high ? GPIOD_LINE_VALUE_ACTIVE : GPIOD_LINE_VALUE_INACTIVE);
      break;
    case GpioMode::input: rc |= gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_INPUT); break;
    case GpioMode::edge_events:
      rc |= gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_INPUT);
      rc |= gpiod_line_settings_set_edge_detection(
          s, spec.edge == Edge::falling ? GPIOD_LINE_EDGE_FALLING : GPIOD_LINE_EDGE_RISING);
      // The loop's latency figures compare edge stamps with CLOCK_MONOTONIC.
      rc |= gpiod_line_settings_set_event_clock(s, GPIOD_LINE_CLOCK_MONOTONIC);
      break;
  }
  if (rc != 0) {
    gpiod_line_settings_free(s);
    errno = EINVAL;
    return nullptr;
  }
  return s;
}

// Requests one line with `settings` for the consumer "gyrotc".
gpiod_line_request* request_line(gpiod_chip* chip, unsigned offset, gpiod_line_settings* settings) noexcept {
  gpiod_line_config* line_config = gpiod_line_config_new();
  gpiod_request_config* request_config = gpiod_request_config_new();
  gpiod_line_request* request = nullptr;
  if (line_config != nullptr && request_config != nullptr &&
      gpiod_line_config_add_line_settings(line_config, &offset, 1, settings) == 0) {
    gpiod_request_config_set_consumer(request_config, GpiodLine::kConsumer);
    request = gpiod_chip_request_lines(chip, request_config, line_config);
  }
  const int saved = errno;
  if (request_config != nullptr) gpiod_request_config_free(request_config);
  if (line_config != nullptr) gpiod_line_config_free(line_config);
  errno = saved;
  return request;
}

}  // namespace

GpiodLine::GpiodLine(std::string name, const GpiodLineSpec& spec, std::unique_ptr<Handles> handles) noexcept
    : name_(std::move(name)), mode_(spec.mode), edge_(spec.edge), handles_(std::move(handles)) {}

GpiodLine::~GpiodLine() = default;

std::string GpiodLine::library_version() { return std::string("libgpiod ") + gpiod_api_version(); }

Result<std::unique_ptr<GpiodLine>> GpiodLine::open(const GpiodLineSpec& spec) noexcept {
  const std::string name = spec.chip + ":" + spec.line;
  auto handles = std::make_unique<Handles>();
  errno = 0;
  handles->chip = open_chip(spec.chip);
  if (handles->chip == nullptr) return Error::from_errno(errno_or(ENOENT), "cannot open gpiochip", spec.chip);

  errno = 0;
  if (!parse_unsigned(spec.line, handles->offset)) {
    const int offset = gpiod_chip_get_line_offset_from_name(handles->chip, spec.line.c_str());
    if (offset < 0) return Error::from_errno(errno_or(ENOENT), "no GPIO line", name);
    handles->offset = static_cast<unsigned>(offset);
  }

  errno = 0;
  gpiod_line_settings* settings = make_settings(spec);
  if (settings == nullptr) return Error::from_errno(errno_or(ENOMEM), "cannot configure GPIO line", name);
  handles->request = request_line(handles->chip, handles->offset, settings);
  const int saved = errno;
  gpiod_line_settings_free(settings);
  if (handles->request == nullptr) return Error::from_errno(saved != 0 ? saved : EIO, "cannot request GPIO line", name);

  if (spec.mode == GpioMode::edge_events) {
    handles->events = gpiod_edge_event_buffer_new(kEventBatch);
    if (handles->events == nullptr) return Error::from_errno(errno_or(ENOMEM), "cannot allocate edge events for GPIO", name);
  }
  return std::unique_ptr<GpiodLine>(new GpiodLine(name, spec, std::move(handles)));
}

Status GpiodLine::do_set(bool high) noexcept {
  if (Status s = check_settable(); !s) return s;
  if (gpiod_line_request_set_value(handles_->request, handles_->offset,
                                   high ? GPIOD_LINE_VALUE_ACTIVE : GPIOD_LINE_VALUE_INACTIVE) < 0) {
    return Error::from_errno(errno, "cannot set GPIO", name_);
  }
  return {};
}

Result<bool> GpiodLine::do_get() noexcept {
  const gpiod_line_value value = gpiod_line_request_get_value(handles_->request, handles_->offset);
  if (value == GPIOD_LINE_VALUE_ERROR) return Error::from_errno(errno, "cannot read GPIO", name_);
  return value == GPIOD_LINE_VALUE_ACTIVE;
}

Result<double> GpiodLine::do_wait_edge(Edge edge, double timeout_s) noexcept {
  if (Status s = check_edge(edge); !s) return s.error();
  const auto timeout_ns = static_cast<std::int64_t>(std::max(0.0, timeout_s) * 1e9);
  const int rc = gpiod_line_request_wait_edge_events(handles_->request, timeout_ns);
  if (rc < 0) return Error::from_errno(errno, "cannot wait for an edge on GPIO", name_);
  if (rc == 0) {
    return Error::make(ErrorCode::timeout, "no %s edge on GPIO '%s' within %.3f s",
                       edge == Edge::rising ? "rising" : "falling", name_.c_str(), timeout_s);
  }
  // One event: later ones stay queued in the kernel for the next wait (or
  // discard_edges()), in order. Only the requested edge is queued.
  if (gpiod_line_request_read_edge_events(handles_->request, handles_->events, 1) < 1) {
    return Error::from_errno(errno_or(EIO), "cannot read an edge of GPIO", name_);
  }
  gpiod_edge_event* event = gpiod_edge_event_buffer_get_event(handles_->events, 0);
  return static_cast<double>(gpiod_edge_event_get_timestamp_ns(event)) * 1e-9;  // CLOCK_MONOTONIC, requested
}

Result<int> GpiodLine::do_discard_edges() noexcept {
  if (mode_ != GpioMode::edge_events) return 0;
  int dropped = 0;
  for (;;) {
    const int rc = gpiod_line_request_wait_edge_events(handles_->request, 0);
    if (rc < 0) return Error::from_errno(errno, "cannot poll the edges of GPIO", name_);
    if (rc == 0) return dropped;
    const int got = gpiod_line_request_read_edge_events(handles_->request, handles_->events, kEventBatch);
    if (got < 0) return Error::from_errno(errno, "cannot read the edges of GPIO", name_);
    dropped += got;
  }
}

}  // namespace gyrotc::hal
