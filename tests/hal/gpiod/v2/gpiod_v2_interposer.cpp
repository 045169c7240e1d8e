// The libgpiod 2.x calls of GpiodLine that reach the kernel, wrapped at link
// time (link.cmake): handles of the armed FakeGpiochip are answered here,
// everything else goes to the real library. The settings and config
// objects are the real library's: the fake reads what GpiodLine configured
// through libgpiod's own getters, as the kernel would receive it.
#include <dirent.h>
#include <gpiod.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "fake_gpiochip.hpp"

namespace {

struct V2Chip {
  FakeGpiochip* fake = nullptr;
};
struct V2Info {
  std::string label;
};
struct V2Request {
  FakeGpiochip* fake = nullptr;
  unsigned offset = 0;
};
struct V2Buffer {
  std::array<FakeEdgeEvent, 64> events{};
  std::size_t capacity = 0;
  std::size_t count = 0;
};
struct V2Dir {
  std::vector<std::string> names;
  std::size_t next = 0;
  dirent entry{};
  dirent64 entry64{};
};

std::set<const void*>& live() {
  static std::set<const void*> handles;
  return handles;
}
bool is_fake(const void* p) { return p != nullptr && live().count(p) != 0; }
template <typename T>
T* make_live(T* p) {
  live().insert(p);
  return p;
}
template <typename T>
void drop(T* p) {
  live().erase(p);
  delete p;
}

std::set<const V2Buffer*>& buffers() {
  static std::set<const V2Buffer*> all;
  return all;
}

// Whether an event pointer points into a fake buffer.
bool in_fake_buffer(const void* event) {
  return std::any_of(buffers().begin(), buffers().end(), [event](const V2Buffer* b) {
    const void* first = b->events.data();
    const void* end = b->events.data() + b->events.size();
    return std::less_equal<const void*>()(first, event) && std::less<const void*>()(event, end);
  });
}

FakeBias bias_of(gpiod_line_bias bias) {
  switch (bias) {
    case GPIOD_LINE_BIAS_DISABLED: return FakeBias::disabled;
    case GPIOD_LINE_BIAS_PULL_UP: return FakeBias::pull_up;
    case GPIOD_LINE_BIAS_PULL_DOWN: return FakeBias::pull_down;
    default: return FakeBias::as_is;
  }
}

FakeEdges edges_of(gpiod_line_edge edge) {
  switch (edge) {
    case GPIOD_LINE_EDGE_RISING: return FakeEdges::rising;
    case GPIOD_LINE_EDGE_FALLING: return FakeEdges::falling;
    case GPIOD_LINE_EDGE_BOTH: return FakeEdges::both;
    default: return FakeEdges::none;
  }
}

FakeClock clock_of(gpiod_line_clock clock) {
  switch (clock) {
    case GPIOD_LINE_CLOCK_MONOTONIC: return FakeClock::monotonic;
    case GPIOD_LINE_CLOCK_REALTIME: return FakeClock::realtime;
    default: return FakeClock::unset;
  }
}

// The fake folder's next name in entry, or nullptr at its end.
template <class Entry>
Entry* next_entry(V2Dir* dir, Entry& entry) {
  if (dir->next == dir->names.size()) return nullptr;
  std::snprintf(entry.d_name, sizeof entry.d_name, "%s", dir->names[dir->next++].c_str());
  return &entry;
}

}  // namespace

extern "C" {
gpiod_chip* __real_gpiod_chip_open(const char* path);
bool __real_gpiod_is_gpiochip_device(const char* path);
void __real_gpiod_chip_close(gpiod_chip* chip);
gpiod_chip_info* __real_gpiod_chip_get_info(gpiod_chip* chip);
const char* __real_gpiod_chip_info_get_label(gpiod_chip_info* info);
void __real_gpiod_chip_info_free(gpiod_chip_info* info);
int __real_gpiod_chip_get_line_offset_from_name(gpiod_chip* chip, const char* name);
gpiod_line_request* __real_gpiod_chip_request_lines(gpiod_chip* chip, gpiod_request_config* req_cfg,
                                                    gpiod_line_config* line_cfg);
void __real_gpiod_line_request_release(gpiod_line_request* request);
gpiod_line_value __real_gpiod_line_request_get_value(gpiod_line_request* request, unsigned offset);
int __real_gpiod_line_request_set_value(gpiod_line_request* request, unsigned offset, gpiod_line_value value);
int __real_gpiod_line_request_wait_edge_events(gpiod_line_request* request, int64_t timeout_ns);
int __real_gpiod_line_request_read_edge_events(gpiod_line_request* request, gpiod_edge_event_buffer* buffer,
                                               size_t max_events);
gpiod_edge_event_buffer* __real_gpiod_edge_event_buffer_new(size_t capacity);
void __real_gpiod_edge_event_buffer_free(gpiod_edge_event_buffer* buffer);
gpiod_edge_event* __real_gpiod_edge_event_buffer_get_event(gpiod_edge_event_buffer* buffer, unsigned long index);
uint64_t __real_gpiod_edge_event_get_timestamp_ns(gpiod_edge_event* event);
DIR* __real_opendir(const char* path);
dirent* __real_readdir(DIR* dir);
dirent64* __real_readdir64(DIR* dir);
int __real_closedir(DIR* dir);

gpiod_chip* __wrap_gpiod_chip_open(const char* path) {
  FakeGpiochip* fake = FakeGpiochip::armed();
  if (fake == nullptr || fake->path() != path) return __real_gpiod_chip_open(path);
  if (fake->open_errno != 0) {
    errno = fake->open_errno;
    return nullptr;
  }
  ++fake->open_handles;
  return reinterpret_cast<gpiod_chip*>(make_live(new V2Chip{fake}));
}

bool __wrap_gpiod_is_gpiochip_device(const char* path) {
  FakeGpiochip* fake = FakeGpiochip::armed();
  if (fake != nullptr && fake->path() == path) return true;
  return __real_gpiod_is_gpiochip_device(path);
}

void __wrap_gpiod_chip_close(gpiod_chip* c) {
  if (!is_fake(c)) return __real_gpiod_chip_close(c);
  auto* chip = reinterpret_cast<V2Chip*>(c);
  --chip->fake->open_handles;
  drop(chip);
}

gpiod_chip_info* __wrap_gpiod_chip_get_info(gpiod_chip* c) {
  if (!is_fake(c)) return __real_gpiod_chip_get_info(c);
  return reinterpret_cast<gpiod_chip_info*>(make_live(new V2Info{reinterpret_cast<V2Chip*>(c)->fake->label}));
}

const char* __wrap_gpiod_chip_info_get_label(gpiod_chip_info* info) {
  if (!is_fake(info)) return __real_gpiod_chip_info_get_label(info);
  return reinterpret_cast<V2Info*>(info)->label.c_str();
}

void __wrap_gpiod_chip_info_free(gpiod_chip_info* info) {
  if (!is_fake(info)) return __real_gpiod_chip_info_free(info);
  drop(reinterpret_cast<V2Info*>(info));
}

int __wrap_gpiod_chip_get_line_offset_from_name(gpiod_chip* c, const char* name) {
  if (!is_fake(c)) return __real_gpiod_chip_get_line_offset_from_name(c, name);
  const auto& lines = reinterpret_cast<V2Chip*>(c)->fake->lines;
  const auto it = std::find_if(lines.begin(), lines.end(), [&](const FakeLine& l) { return l.name == name; });
  if (it == lines.end()) {
    errno = ENOENT;
    return -1;
  }
  return static_cast<int>(it - lines.begin());
}

gpiod_line_request* __wrap_gpiod_chip_request_lines(gpiod_chip* c, gpiod_request_config* req_cfg,
                                                    gpiod_line_config* line_cfg) {
  if (!is_fake(c)) return __real_gpiod_chip_request_lines(c, req_cfg, line_cfg);
  FakeGpiochip* fake = reinterpret_cast<V2Chip*>(c)->fake;
  unsigned offsets[4];
  if (gpiod_line_config_get_num_configured_offsets(line_cfg) != 1 ||
      gpiod_line_config_get_configured_offsets(line_cfg, offsets, 4) != 1 || fake->line(offsets[0]) == nullptr) {
    errno = EINVAL;
    return nullptr;
  }
  FakeLine& f = *fake->line(offsets[0]);
  if (f.requested) {
    errno = EBUSY;
    return nullptr;
  }
  gpiod_line_settings* s = gpiod_line_config_get_line_settings(line_cfg, offsets[0]);
  if (s == nullptr) return nullptr;
  const char* consumer = req_cfg != nullptr ? gpiod_request_config_get_consumer(req_cfg) : nullptr;
  f.requested = true;
  f.consumer = consumer != nullptr ? consumer : "";
  f.direction = gpiod_line_settings_get_direction(s) == GPIOD_LINE_DIRECTION_OUTPUT ? FakeDirection::output
                                                                                    : FakeDirection::input;
  f.open_drain = gpiod_line_settings_get_drive(s) == GPIOD_LINE_DRIVE_OPEN_DRAIN;
  f.bias = bias_of(gpiod_line_settings_get_bias(s));
  f.active_low = gpiod_line_settings_get_active_low(s);
  f.edges = edges_of(gpiod_line_settings_get_edge_detection(s));
  f.clock = f.edges == FakeEdges::none ? FakeClock::unset : clock_of(gpiod_line_settings_get_event_clock(s));
  f.events.clear();
  if (f.direction == FakeDirection::output) {
    const int value = gpiod_line_settings_get_output_value(s) == GPIOD_LINE_VALUE_ACTIVE ? 1 : 0;
    f.level = value ^ (f.active_low ? 1 : 0);
  }
  gpiod_line_settings_free(s);
  return reinterpret_cast<gpiod_line_request*>(make_live(new V2Request{fake, offsets[0]}));
}

void __wrap_gpiod_line_request_release(gpiod_line_request* r) {
  if (!is_fake(r)) return __real_gpiod_line_request_release(r);
  auto* request = reinterpret_cast<V2Request*>(r);
  request->fake->lines[request->offset].requested = false;
  drop(request);
}

gpiod_line_value __wrap_gpiod_line_request_get_value(gpiod_line_request* r, unsigned offset) {
  if (!is_fake(r)) return __real_gpiod_line_request_get_value(r, offset);
  auto* request = reinterpret_cast<V2Request*>(r);
  if (offset != request->offset) {
    errno = EINVAL;
    return GPIOD_LINE_VALUE_ERROR;
  }
  return request->fake->lines[offset].logical() != 0 ? GPIOD_LINE_VALUE_ACTIVE : GPIOD_LINE_VALUE_INACTIVE;
}

int __wrap_gpiod_line_request_set_value(gpiod_line_request* r, unsigned offset, gpiod_line_value value) {
  if (!is_fake(r)) return __real_gpiod_line_request_set_value(r, offset, value);
  auto* request = reinterpret_cast<V2Request*>(r);
  FakeLine& f = request->fake->lines[request->offset];
  if (offset != request->offset || f.direction != FakeDirection::output) {
    errno = EPERM;
    return -1;
  }
  f.level = (value == GPIOD_LINE_VALUE_ACTIVE ? 1 : 0) ^ (f.active_low ? 1 : 0);
  return 0;
}

int __wrap_gpiod_line_request_wait_edge_events(gpiod_line_request* r, int64_t timeout_ns) {
  if (!is_fake(r)) return __real_gpiod_line_request_wait_edge_events(r, timeout_ns);
  auto* request = reinterpret_cast<V2Request*>(r);
  FakeLine& f = request->fake->lines[request->offset];
  f.last_wait_timeout_ns = timeout_ns;
  return f.events.empty() ? 0 : 1;  // no waiting: a test's edges are queued before it waits
}

int __wrap_gpiod_line_request_read_edge_events(gpiod_line_request* r, gpiod_edge_event_buffer* b,
                                               size_t max_events) {
  if (!is_fake(r)) return __real_gpiod_line_request_read_edge_events(r, b, max_events);
  auto* request = reinterpret_cast<V2Request*>(r);
  auto* buffer = reinterpret_cast<V2Buffer*>(b);
  FakeLine& f = request->fake->lines[request->offset];
  if (!is_fake(b) || f.events.empty()) {
    errno = EINVAL;  // the real read would block on an empty queue; the tests never ask for that
    return -1;
  }
  buffer->count = 0;
  while (buffer->count < std::min(max_events, buffer->capacity) && !f.events.empty()) {
    buffer->events[buffer->count++] = f.events.front();
    f.events.pop_front();
  }
  return static_cast<int>(buffer->count);
}

gpiod_edge_event_buffer* __wrap_gpiod_edge_event_buffer_new(size_t capacity) {
  if (FakeGpiochip::armed() == nullptr) return __real_gpiod_edge_event_buffer_new(capacity);
  auto* buffer = new V2Buffer;
  buffer->capacity = std::min<std::size_t>(capacity == 0 ? 64 : capacity, buffer->events.size());
  buffers().insert(buffer);
  return reinterpret_cast<gpiod_edge_event_buffer*>(make_live(buffer));
}

void __wrap_gpiod_edge_event_buffer_free(gpiod_edge_event_buffer* b) {
  if (!is_fake(b)) return __real_gpiod_edge_event_buffer_free(b);
  buffers().erase(reinterpret_cast<V2Buffer*>(b));
  drop(reinterpret_cast<V2Buffer*>(b));
}

gpiod_edge_event* __wrap_gpiod_edge_event_buffer_get_event(gpiod_edge_event_buffer* b, unsigned long index) {
  if (!is_fake(b)) return __real_gpiod_edge_event_buffer_get_event(b, index);
  auto* buffer = reinterpret_cast<V2Buffer*>(b);
  if (index >= buffer->count) {
    errno = EINVAL;
    return nullptr;
  }
  return reinterpret_cast<gpiod_edge_event*>(&buffer->events[index]);
}

uint64_t __wrap_gpiod_edge_event_get_timestamp_ns(gpiod_edge_event* event) {
  if (!in_fake_buffer(event)) return __real_gpiod_edge_event_get_timestamp_ns(event);
  return reinterpret_cast<FakeEdgeEvent*>(event)->time_ns;
}

// /dev as GpiodLine scans it for a chip label: the fake chip and a non-chip.
DIR* __wrap_opendir(const char* path) {
  FakeGpiochip* fake = FakeGpiochip::armed();
  if (fake == nullptr || std::strcmp(path, "/dev") != 0) return __real_opendir(path);
  return reinterpret_cast<DIR*>(make_live(new V2Dir{{"null", "gpiochip-not-a-chip", fake->name}}));
}

dirent* __wrap_readdir(DIR* d) {
  if (!is_fake(d)) return __real_readdir(d);
  auto* dir = reinterpret_cast<V2Dir*>(d);
  return next_entry(dir, dir->entry);
}

// With _FILE_OFFSET_BITS=64 (the project sets it for 32-bit targets, and it
// applies everywhere), glibc's <dirent.h> makes readdir() readdir64(), on
// 64-bit targets too: a fake folder must answer both.
dirent64* __wrap_readdir64(DIR* d) {
  if (!is_fake(d)) return __real_readdir64(d);
  auto* dir = reinterpret_cast<V2Dir*>(d);
  return next_entry(dir, dir->entry64);
}

int __wrap_closedir(DIR* d) {
  if (!is_fake(d)) return __real_closedir(d);
  drop(reinterpret_cast<V2Dir*>(d));
  return 0;
}
}
