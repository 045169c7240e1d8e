#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

// A GPIO chip as the kernel's character device presents it, behind link-time
// wrappers of the libgpiod calls (v1/ or v2/ interposer, whichever API the
// build uses): lines with a consumer, direction, drive, bias, active-low
// and edge detection, a pin level the test drives, and a queue of edge
// events filled the way gpiolib-cdev fills it: only the requested edges, in
// logical terms (active-low inverts), stamped with the time the test gives.
// Every other chip goes to the real libgpiod.
enum class FakeDirection { input, output };
enum class FakeBias { as_is, disabled, pull_up, pull_down };
enum class FakeEdges { none, rising, falling, both };
enum class FakeClock { unset, monotonic, realtime };

struct FakeEdgeEvent {
  bool rising = false;
  std::uint64_t time_ns = 0;
};

struct FakeLine {
  std::string name;
  // The request, as the kernel holds it.
  bool requested = false;
  std::string consumer;
  FakeDirection direction = FakeDirection::input;
  bool open_drain = false;
  FakeBias bias = FakeBias::as_is;
  bool active_low = false;
  FakeEdges edges = FakeEdges::none;
  FakeClock clock = FakeClock::unset;
  // The pin.
  int level = 0;
  std::deque<FakeEdgeEvent> events;
  std::int64_t last_wait_timeout_ns = -2;  // what the last wait asked for; -2: none yet

  int logical() const { return level ^ (active_low ? 1 : 0); }
};

struct FakeGpiochip {
  std::string name = "gpiochip7";
  std::string label = "fake-pinctrl";
  int open_handles = 0;
  int open_errno = 0;  // opening the chip fails with this (EACCES: a node the process may not open)
  std::vector<FakeLine> lines;

  FakeGpiochip();
  std::string path() const { return "/dev/" + name; }
  // A chip description as gpiod_chip_open_lookup (v1) takes it: name, path,
  // label or number.
  bool matches(const std::string& description) const;
  // Drives the pin of `offset` to `level` at `time_ns`; queues an edge
  // event if the line is requested for that (logical) edge.
  void drive(unsigned offset, int level, std::uint64_t time_ns);
  // The line a request answers for, or null.
  FakeLine* line(unsigned offset) { return offset < lines.size() ? &lines[offset] : nullptr; }

  static FakeGpiochip*& armed();  // the fake in use, or nullptr
};

// CLOCK_MONOTONIC now, in ns: the stamps the tests give their edges.
std::uint64_t monotonic_now_ns();
