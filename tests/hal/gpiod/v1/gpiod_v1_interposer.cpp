// The libgpiod 1.6 calls of GpiodLine, wrapped at link time (link.cmake):
// handles of the armed FakeGpiochip are answered here, everything else goes
// to the real library.
#include <gpiod.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <memory>
#include <set>
#include <string>

#include "fake_gpiochip.hpp"

namespace {

struct V1Chip;
struct V1Line {
  V1Chip* chip = nullptr;
  unsigned offset = 0;
};
// One gpiod_chip_open_lookup: its own handle, whose close releases the lines
// requested through it (as the real chip's file descriptor does).
struct V1Chip {
  FakeGpiochip* fake = nullptr;
  std::array<V1Line, 32> lines{};
  std::set<unsigned> requested;
};

std::set<const void*>& live() {
  static std::set<const void*> handles;
  return handles;
}
bool is_fake(const void* p) { return p != nullptr && live().count(p) != 0; }
V1Chip* chip_of(gpiod_chip* c) { return reinterpret_cast<V1Chip*>(c); }
V1Line* line_of(gpiod_line* l) { return reinterpret_cast<V1Line*>(l); }
FakeLine& fake_line(gpiod_line* l) { return line_of(l)->chip->fake->lines[line_of(l)->offset]; }

FakeBias bias_of(int flags) {
  if ((flags & GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE) != 0) return FakeBias::disabled;
  if ((flags & GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP) != 0) return FakeBias::pull_up;
  if ((flags & GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN) != 0) return FakeBias::pull_down;
  return FakeBias::as_is;
}

int request(gpiod_line* l, const char* consumer, int flags, FakeDirection direction, FakeEdges edges, int value) {
  FakeLine& f = fake_line(l);
  if (f.requested) {
    errno = EBUSY;
    return -1;
  }
  f.requested = true;
  f.consumer = consumer;
  f.direction = direction;
  f.open_drain = (flags & GPIOD_LINE_REQUEST_FLAG_OPEN_DRAIN) != 0;
  f.bias = bias_of(flags);
  f.active_low = (flags & GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW) != 0;
  f.edges = edges;
  // The uAPI v1 has no clock choice: CLOCK_MONOTONIC since Linux 5.7.
  f.clock = edges == FakeEdges::none ? FakeClock::unset : FakeClock::monotonic;
  f.events.clear();
  if (direction == FakeDirection::output) f.level = (value != 0 ? 1 : 0) ^ (f.active_low ? 1 : 0);
  line_of(l)->chip->requested.insert(line_of(l)->offset);
  return 0;
}

void to_event(const FakeEdgeEvent& e, gpiod_line_event* out) {
  out->event_type = e.rising ? GPIOD_LINE_EVENT_RISING_EDGE : GPIOD_LINE_EVENT_FALLING_EDGE;
  out->ts.tv_sec = static_cast<time_t>(e.time_ns / 1'000'000'000u);
  out->ts.tv_nsec = static_cast<long>(e.time_ns % 1'000'000'000u);
}

}  // namespace

extern "C" {
gpiod_chip* __real_gpiod_chip_open_lookup(const char* description);
void __real_gpiod_chip_close(gpiod_chip* chip);
gpiod_line* __real_gpiod_chip_get_line(gpiod_chip* chip, unsigned offset);
gpiod_line* __real_gpiod_chip_find_line(gpiod_chip* chip, const char* name);
int __real_gpiod_line_request_output_flags(gpiod_line* line, const char* consumer, int flags, int value);
int __real_gpiod_line_request_input_flags(gpiod_line* line, const char* consumer, int flags);
int __real_gpiod_line_request_falling_edge_events_flags(gpiod_line* line, const char* consumer, int flags);
int __real_gpiod_line_request_rising_edge_events_flags(gpiod_line* line, const char* consumer, int flags);
int __real_gpiod_line_set_value(gpiod_line* line, int value);
int __real_gpiod_line_get_value(gpiod_line* line);
int __real_gpiod_line_event_wait(gpiod_line* line, const timespec* timeout);
int __real_gpiod_line_event_read(gpiod_line* line, gpiod_line_event* event);
int __real_gpiod_line_event_read_multiple(gpiod_line* line, gpiod_line_event* events, unsigned num_events);

gpiod_chip* __wrap_gpiod_chip_open_lookup(const char* description) {
  FakeGpiochip* fake = FakeGpiochip::armed();
  if (fake == nullptr || !fake->matches(description)) return __real_gpiod_chip_open_lookup(description);
  if (fake->open_errno != 0) {  // libgpiod 1.6 reports the chip it could not open, even in a label lookup
    errno = fake->open_errno;
    return nullptr;
  }
  auto* chip = new V1Chip;
  chip->fake = fake;
  for (unsigned i = 0; i < chip->lines.size(); ++i) {
    chip->lines[i] = {chip, i};
    live().insert(&chip->lines[i]);
  }
  live().insert(chip);
  ++fake->open_handles;
  return reinterpret_cast<gpiod_chip*>(chip);
}

void __wrap_gpiod_chip_close(gpiod_chip* c) {
  if (!is_fake(c)) return __real_gpiod_chip_close(c);
  V1Chip* chip = chip_of(c);
  for (unsigned offset : chip->requested) chip->fake->lines[offset].requested = false;
  --chip->fake->open_handles;
  for (auto& l : chip->lines) live().erase(&l);
  live().erase(chip);
  delete chip;
}

gpiod_line* __wrap_gpiod_chip_get_line(gpiod_chip* c, unsigned offset) {
  if (!is_fake(c)) return __real_gpiod_chip_get_line(c, offset);
  if (offset >= chip_of(c)->fake->lines.size()) {
    errno = EINVAL;
    return nullptr;
  }
  return reinterpret_cast<gpiod_line*>(&chip_of(c)->lines[offset]);
}

gpiod_line* __wrap_gpiod_chip_find_line(gpiod_chip* c, const char* name) {
  if (!is_fake(c)) return __real_gpiod_chip_find_line(c, name);
  const auto& lines = chip_of(c)->fake->lines;
  const auto it = std::find_if(lines.begin(), lines.end(), [&](const FakeLine& l) { return l.name == name; });
  if (it == lines.end()) {
    errno = ENOENT;
    return nullptr;
  }
  return reinterpret_cast<gpiod_line*>(&chip_of(c)->lines[static_cast<std::size_t>(it - lines.begin())]);
}

int __wrap_gpiod_line_request_output_flags(gpiod_line* l, const char* consumer, int flags, int value) {
  if (!is_fake(l)) return __real_gpiod_line_request_output_flags(l, consumer, flags, value);
  return request(l, consumer, flags, FakeDirection::output, FakeEdges::none, value);
}

int __wrap_gpiod_line_request_input_flags(gpiod_line* l, const char* consumer, int flags) {
  if (!is_fake(l)) return __real_gpiod_line_request_input_flags(l, consumer, flags);
  return request(l, consumer, flags, FakeDirection::input, FakeEdges::none, 0);
}

int __wrap_gpiod_line_request_falling_edge_events_flags(gpiod_line* l, const char* consumer, int flags) {
  if (!is_fake(l)) return __real_gpiod_line_request_falling_edge_events_flags(l, consumer, flags);
  return request(l, consumer, flags, FakeDirection::input, FakeEdges::falling, 0);
}

int __wrap_gpiod_line_request_rising_edge_events_flags(gpiod_line* l, const char* consumer, int flags) {
  if (!is_fake(l)) return __real_gpiod_line_request_rising_edge_events_flags(l, consumer, flags);
  return request(l, consumer, flags, FakeDirection::input, FakeEdges::rising, 0);
}

int __wrap_gpiod_line_set_value(gpiod_line* l, int value) {
  if (!is_fake(l)) return __real_gpiod_line_set_value(l, value);
  FakeLine& f = fake_line(l);
  if (!f.requested || f.direction != FakeDirection::output) {
    errno = EPERM;
    return -1;
  }
  f.level = (value != 0 ? 1 : 0) ^ (f.active_low ? 1 : 0);
  return 0;
}

int __wrap_gpiod_line_get_value(gpiod_line* l) {
  if (!is_fake(l)) return __real_gpiod_line_get_value(l);
  const FakeLine& f = fake_line(l);
  if (!f.requested) {
    errno = EPERM;
    return -1;
  }
  return f.logical();
}

int __wrap_gpiod_line_event_wait(gpiod_line* l, const timespec* timeout) {
  if (!is_fake(l)) return __real_gpiod_line_event_wait(l, timeout);
  FakeLine& f = fake_line(l);
  if (f.edges == FakeEdges::none) {
    errno = EPERM;
    return -1;
  }
  f.last_wait_timeout_ns = timeout == nullptr ? -1 : timeout->tv_sec * 1'000'000'000LL + timeout->tv_nsec;
  return f.events.empty() ? 0 : 1;  // no waiting: a test's edges are queued before it waits
}

int __wrap_gpiod_line_event_read(gpiod_line* l, gpiod_line_event* event) {
  if (!is_fake(l)) return __real_gpiod_line_event_read(l, event);
  FakeLine& f = fake_line(l);
  if (f.events.empty()) {
    errno = EAGAIN;  // the real read would block; the tests never ask for that
    return -1;
  }
  to_event(f.events.front(), event);
  f.events.pop_front();
  return 0;
}

int __wrap_gpiod_line_event_read_multiple(gpiod_line* l, gpiod_line_event* events, unsigned num_events) {
  if (!is_fake(l)) return __real_gpiod_line_event_read_multiple(l, events, num_events);
  FakeLine& f = fake_line(l);
  unsigned n = 0;
  for (; n < num_events && !f.events.empty(); ++n) {
    to_event(f.events.front(), &events[n]);
    f.events.pop_front();
  }
  if (n == 0) {
    errno = EAGAIN;
    return -1;
  }
  return static_cast<int>(n);
}
}
