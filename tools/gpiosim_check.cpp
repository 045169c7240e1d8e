// hal::GpiodLine against a real kernel GPIO chip: the gpio-sim driver
// (drivers/gpio/gpio-sim.c), whose line levels a test sets through sysfs
// (sim_gpio<N>/pull) and whose outputs it reads back (sim_gpio<N>/value).
// scripts/vm-test.sh builds gpio-sim for the kernel of its virtual board,
// creates the chip through configfs and runs this inside the VM; it needs
// root (sysfs writes), so it is not part of the test suite.
//
//   gpiosim_check --chip gpiochip1 --sim-dir /sys/devices/platform/gpio-sim.0/gpiochip1
//                 [--drdy DRDY --drdy-offset 0] [--es OPA548_ES --es-offset 1] [--label L]
//
// Prints one "PASS <check>: ..." or "FAIL <check>: ..." line per check and
// exits 0 only if all passed.

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "gyrotc/hal/chips/opa548.hpp"
#include "gyrotc/hal/linux/gpiod_line.hpp"

namespace {

using namespace gyrotc::hal;

struct Options {
  std::string chip;     // as in a configuration: name, path, label or number
  std::string sim_dir;  // /sys/devices/platform/gpio-sim.N/gpiochipM
  std::string label;    // the bank's label (configfs), for the lookup check; "" = skip
  std::string drdy = "DRDY";
  unsigned drdy_offset = 0;
  std::string es = "OPA548_ES";
  unsigned es_offset = 1;
  unsigned edge_gap_ms = 30;  // after each falling edge (see EdgeDriver)
};

double monotonic_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

int failures = 0;

void report(bool ok, const char* check, const std::string& detail) {
  if (!ok) ++failures;
  std::printf("%s %s: %s\n", ok ? "PASS" : "FAIL", check, detail.c_str());
  std::fflush(stdout);
}

std::string text(const Error& e) { return std::string(e.message()); }

// One simulated line: its level is the pull the test sets (what the wire
// would carry), its value what the requester drives.
class SimLine {
 public:
  SimLine(const std::string& sim_dir, unsigned offset)
      : dir_(sim_dir + "/sim_gpio" + std::to_string(offset)) {}

  // false with errno on failure.
  bool set_pull(bool high) {
    const int fd = ::open((dir_ + "/pull").c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) return false;
    const char* value = high ? "pull-up" : "pull-down";
    const ssize_t n = ::write(fd, value, std::strlen(value));
    const int saved = errno;
    ::close(fd);
    errno = saved;
    return n == static_cast<ssize_t>(std::strlen(value));
  }
  // 0 or 1, -1 on error.
  int value() const {
    char buf[8] = {};
    const int fd = ::open((dir_ + "/value").c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    const ssize_t n = ::read(fd, buf, sizeof buf - 1);
    ::close(fd);
    if (n < 1) return -1;
    return buf[0] == '1' ? 1 : buf[0] == '0' ? 0 : -1;
  }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
};

// Drives a pin level sequence and remembers, for each falling edge, the
// monotonic time just before the write that made it. The kernel stamps an
// edge in its hard interrupt handler and queues it from the line's IRQ
// thread; edges that come faster than that thread runs are merged into one
// event (on a board too: the ADS1251's data bits at SCLK rate are). So each
// falling edge is followed by a pause long enough for the thread, and the
// checks can count every edge.
class EdgeDriver {
 public:
  EdgeDriver(SimLine& line, double gap_s) : line_(line), gap_s_(gap_s) {}

  bool level(bool high) {
    if (high == high_) return true;
    const double before = monotonic_s();
    if (!line_.set_pull(high)) return false;
    high_ = high;
    if (!high) {
      falls_s_.push_back(before);
      const timespec gap{static_cast<time_t>(gap_s_), static_cast<long>((gap_s_ - std::floor(gap_s_)) * 1e9)};
      nanosleep(&gap, nullptr);
    }
    return true;
  }
  // The ADS1251's shared DRDY/DOUT pin over one conversion: DRDY falls, the
  // 24 data bits follow MSB first (the test's SCLK), then the pin idles high.
  // Returns false on a write error.
  bool conversion(std::uint32_t word) { return drdy() && data_bits(word) && level(true); }
  bool drdy() { return level(true) && level(false); }
  bool data_bits(std::uint32_t word) {
    for (int bit = 23; bit >= 0; --bit) {
      if (!level(((word >> bit) & 1u) != 0)) return false;
    }
    return true;
  }
  std::vector<double>& falls_s() { return falls_s_; }

 private:
  SimLine& line_;
  double gap_s_;
  bool high_ = false;  // gpio-sim lines start pulled down
  std::vector<double> falls_s_;
};

std::string fmt(const char* format, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

std::unique_ptr<GpiodLine> open_or_report(const char* check, const GpiodLineSpec& spec) {
  auto line = GpiodLine::open(spec);
  if (!line) {
    report(false, check, "cannot open " + spec.chip + ":" + spec.line + ": " + text(line.error()));
    return nullptr;
  }
  return std::move(line.value());
}

// A falling edge arrives as one event whose stamp is CLOCK_MONOTONIC: after
// the write that made it and before wait_edge returned.
void check_single_edge(GpiodLine& drdy, EdgeDriver& pin) {
  pin.falls_s().clear();
  if (!pin.drdy()) return report(false, "gpio-drdy-edge", std::string("sysfs pull: ") + std::strerror(errno));
  auto stamp = drdy.wait_edge(Edge::falling, 5.0);
  const double back_s = monotonic_s();
  if (!stamp) return report(false, "gpio-drdy-edge", text(stamp.error()));
  const double fall_s = pin.falls_s().front();
  const bool ok = *stamp >= fall_s && *stamp <= back_s;
  report(ok, "gpio-drdy-edge",
         fmt("falling edge stamped %.6f s (CLOCK_MONOTONIC), %.1f us after the pull write, %.1f us before "
             "wait_edge returned",
             *stamp, (*stamp - fall_s) * 1e6, (back_s - *stamp) * 1e6) +
             (ok ? "" : ": outside the window, not CLOCK_MONOTONIC"));
}

// No edge: a timeout after the time asked for. A rising edge is not one:
// the line was requested for falling edges only.
void check_timeout(GpiodLine& drdy, EdgeDriver& pin) {
  constexpr double kTimeout = 0.25;
  if (!pin.level(true)) return report(false, "gpio-drdy-timeout", std::string("sysfs pull: ") + std::strerror(errno));
  const double start_s = monotonic_s();
  auto stamp = drdy.wait_edge(Edge::falling, kTimeout);
  const double waited_s = monotonic_s() - start_s;
  if (stamp) return report(false, "gpio-drdy-timeout", fmt("an edge stamped %.6f s came after a rising edge only", *stamp));
  const bool ok = stamp.error().code() == ErrorCode::timeout && waited_s >= kTimeout;
  char buf[320];
  std::snprintf(buf, sizeof buf, "after a rising edge only, returned after %.3f s (asked %.3f s): %s", waited_s,
                kTimeout, text(stamp.error()).c_str());
  report(ok, "gpio-drdy-timeout", buf);
}

// Per conversion, as the ADS1251 driver reads it: wait for DRDY, shift the
// word out (each 1->0 data bit is another falling edge on the shared pin),
// then drop those edges with discard_edges().
void check_conversions(GpiodLine& drdy, EdgeDriver& pin) {
  const std::uint32_t words[] = {0xA5F00Fu, 0x5A0FF0u, 0x800001u, 0x000000u, 0xFFFFFFu, 0x6DB6DBu};
  int conversions = 0;
  int data_edges = 0;
  for (const std::uint32_t word : words) {
    pin.falls_s().clear();
    if (!pin.drdy()) return report(false, "gpio-drdy-conversions", std::string("sysfs pull: ") + std::strerror(errno));
    auto stamp = drdy.wait_edge(Edge::falling, 5.0);
    if (!stamp) return report(false, "gpio-drdy-conversions", "DRDY of conversion " + std::to_string(conversions) + ": " + text(stamp.error()));
    if (*stamp < pin.falls_s().front()) {
      return report(false, "gpio-drdy-conversions", fmt("DRDY stamp %.6f s before its edge (%.6f s)", *stamp, pin.falls_s().front()));
    }
    pin.falls_s().clear();
    if (!pin.data_bits(word) || !pin.level(true)) {
      return report(false, "gpio-drdy-conversions", std::string("sysfs pull: ") + std::strerror(errno));
    }
    const int made = static_cast<int>(pin.falls_s().size());
    auto dropped = drdy.discard_edges();
    if (!dropped) return report(false, "gpio-drdy-conversions", text(dropped.error()));
    if (*dropped != made) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "word 0x%06X: %d data-bit falling edges made, discard_edges() dropped %d",
                    word, made, *dropped);
      return report(false, "gpio-drdy-conversions", buf);
    }
    data_edges += made;
    ++conversions;
  }
  auto stray = drdy.wait_edge(Edge::falling, 0.1);
  if (stray) return report(false, "gpio-drdy-conversions", fmt("a stray edge stamped %.6f s after the last discard", *stray));
  report(true, "gpio-drdy-conversions",
         std::to_string(conversions) + " conversions: each DRDY edge waited for, its " +
             "data-bit edges (" + std::to_string(data_edges) + " in all) dropped by discard_edges(), nothing left");
}

// Edges nobody waited for stay queued in order (the kernel keeps 16 per
// line), each stamped between its own write and the next.
void check_queue(GpiodLine& drdy, EdgeDriver& pin) {
  pin.falls_s().clear();
  // Two conversions, 14 falling edges: within the kernel's 16-event buffer.
  if (!pin.conversion(0xA5F00Fu) || !pin.conversion(0x6DB6DBu)) {
    return report(false, "gpio-edge-queue", std::string("sysfs pull: ") + std::strerror(errno));
  }
  const std::vector<double> falls = pin.falls_s();
  std::vector<double> stamps;
  for (;;) {
    auto stamp = drdy.wait_edge(Edge::falling, 0.2);
    if (!stamp) {
      if (stamp.error().code() != ErrorCode::timeout) return report(false, "gpio-edge-queue", text(stamp.error()));
      break;
    }
    stamps.push_back(*stamp);
  }
  const double read_s = monotonic_s();
  if (stamps.size() != falls.size()) {
    return report(false, "gpio-edge-queue",
                  std::to_string(falls.size()) + " falling edges made, " + std::to_string(stamps.size()) +
                      " read (edges closer than the kernel's IRQ thread latency merge: --edge-gap-ms)");
  }
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    const double until_s = i + 1 < falls.size() ? falls[i + 1] : read_s;
    if (stamps[i] < falls[i] || stamps[i] > until_s) {
      return report(false, "gpio-edge-queue",
                    "edge " + std::to_string(i) + fmt(": stamp %.6f s outside its window %.6f .. %.6f s", stamps[i], falls[i], until_s));
    }
  }
  report(true, "gpio-edge-queue",
         std::to_string(stamps.size()) + " queued edges of two conversions read in order, each stamped between its "
         "write and the next" + fmt(" (spread %.1f ms)", (stamps.back() - stamps.front()) * 1e3));
}

// discard_edges() drops everything queued, and only that.
void check_discard(GpiodLine& drdy, EdgeDriver& pin) {
  pin.falls_s().clear();
  for (int i = 0; i < 12; ++i) {
    if (!pin.drdy()) return report(false, "gpio-discard", std::string("sysfs pull: ") + std::strerror(errno));
  }
  const int made = static_cast<int>(pin.falls_s().size());
  auto dropped = drdy.discard_edges();
  if (!dropped) return report(false, "gpio-discard", text(dropped.error()));
  auto after = drdy.wait_edge(Edge::falling, 0.1);
  const bool empty = !after && after.error().code() == ErrorCode::timeout;
  report(*dropped == made && empty, "gpio-discard",
         std::to_string(made) + " edges made, discard_edges() dropped " + std::to_string(*dropped) +
             (empty ? ", the next wait timed out" : ", but an edge was still queued"));
}

// The OPA548 E/S drive as LinuxBoard requests it: push-pull output, low at
// request time. The pin is pulled up first (the worst wiring: E/S floating
// to enabled), so a low value can only come from the request itself.
void check_es(const Options& o, SimLine& es_pin, std::unique_ptr<GpiodLine>& es_out) {
  if (!es_pin.set_pull(true)) return report(false, "gpio-es-output", std::string("sysfs pull: ") + std::strerror(errno));
  const int floating = es_pin.value();
  es_out = open_or_report("gpio-es-output", {.chip = o.chip, .line = o.es, .mode = GpioMode::output,
                                               .open_drain = false, .initial_high = false});
  if (!es_out) return;
  const int requested = es_pin.value();
  Opa548 opa(*es_out, nullptr);
  const Status on = opa.enable(true);
  const int enabled = es_pin.value();
  const Status off = opa.enable(false);
  const int disabled = es_pin.value();
  const bool ok = floating == 1 && requested == 0 && on && enabled == 1 && off && disabled == 0;
  char buf[200];
  std::snprintf(buf, sizeof buf, "E/S pulled up: %d unrequested, %d once requested, %d after enable(true), %d after "
                "enable(false)%s", floating, requested, enabled, disabled, ok ? "" : " (want 1, 0, 1, 0)");
  report(ok, "gpio-es-output", buf);
}

// gpioinfo (libgpiod's tool) shows both lines used by "gyrotc".
void check_consumers(const Options& o) {
  const bool v2 = GpiodLine::library_version().find("libgpiod 1.") == std::string::npos;
  const std::string command = (v2 ? "gpioinfo -c " : "gpioinfo ") + o.chip + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return report(false, "gpio-consumers", "cannot run " + command);
  std::string drdy_line;
  std::string es_line;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) {
    const std::string line(buf);
    if (line.find("\"" + o.drdy + "\"") != std::string::npos) drdy_line = line;
    if (line.find("\"" + o.es + "\"") != std::string::npos) es_line = line;
  }
  const int status = ::pclose(pipe);
  const auto used_by_us = [](const std::string& l) { return l.find("gyrotc") != std::string::npos; };
  // libgpiod 2's gpioinfo also shows the requested edge (and the event
  // clock only when it is not the default, CLOCK_MONOTONIC).
  const bool drdy_flags = !v2 || (drdy_line.find("edges=falling") != std::string::npos &&
                                  drdy_line.find("event-clock=") == std::string::npos);
  const bool es_output = es_line.find("output") != std::string::npos;
  const bool ok = status == 0 && used_by_us(drdy_line) && used_by_us(es_line) && drdy_flags && es_output;
  const auto trim = [](std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    std::string out;
    bool space = false;
    for (char c : s) {
      const bool ws = c == ' ' || c == '\t';
      if (ws && space) continue;
      out += ws ? ' ' : c;
      space = ws;
    }
    return out;
  };
  report(ok, "gpio-consumers", command.substr(0, command.size() - 5) + ": [" + trim(drdy_line) + "] [" + trim(es_line) + "]");
}

// The chip as a configuration may name it: path, number, label.
void check_lookup(const Options& o) {
  const std::string number = o.chip.substr(o.chip.find_first_of("0123456789"));
  std::vector<std::string> names = {"/dev/" + o.chip, number};
  if (!o.label.empty()) names.push_back(o.label);
  std::string shown;
  for (const std::string& name : names) {
    auto line = GpiodLine::open({.chip = name, .line = std::to_string(o.drdy_offset), .mode = GpioMode::input});
    if (!line) return report(false, "gpio-chip-lookup", "'" + name + "': " + text(line.error()));
    shown += (shown.empty() ? "" : ", ") + std::string("'") + name + "'";
  }
  report(true, "gpio-chip-lookup", "line " + std::to_string(o.drdy_offset) + " opened through " + shown);
}

void usage() {
  std::fputs(
      "usage: gpiosim_check --chip CHIP --sim-dir DIR [--label LABEL] [--drdy NAME] [--drdy-offset N]\n"
      "                     [--es NAME] [--es-offset N] [--edge-gap-ms MS]\n"
      "Checks gyrotc's libgpiod back-end (hal::GpiodLine) against a gpio-sim chip: falling edges driven\n"
      "through DIR/sim_gpio<N>/pull arrive with CLOCK_MONOTONIC stamps, timeouts, queued bursts and\n"
      "discard_edges(), the OPA548 E/S output level, consumer names in gpioinfo. Needs root.\n"
      "  --chip     the chip as a configuration names it (gpiochip1)\n"
      "  --sim-dir  the chip's gpio-sim sysfs folder (/sys/devices/platform/gpio-sim.0/gpiochip1)\n"
      "  --label    the bank's label, to check lookup by label (default: skipped)\n"
      "  --drdy, --drdy-offset  the DRDY line's name and offset (DRDY, 0)\n"
      "  --es, --es-offset      the OPA548 E/S line's name and offset (OPA548_ES, 1)\n"
      "  --edge-gap-ms          pause after each falling edge, for the kernel to queue it (30)\n",
      stderr);
}

bool parse_number(const std::string& option, const std::string& value, unsigned long max, unsigned& number) {
  char* end = nullptr;
  const unsigned long n = std::strtoul(value.c_str(), &end, 10);
  if (value.empty() || *end != '\0' || n > max) {
    std::fprintf(stderr, "gpiosim_check: %s: want a whole number 0..%lu, got '%s'\n", option.c_str(), max, value.c_str());
    return false;
  }
  number = static_cast<unsigned>(n);
  return true;
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") return false;
    if (i + 1 >= argc) {
      std::fprintf(stderr, "gpiosim_check: %s needs a value\n", arg.c_str());
      return false;
    }
    const std::string value = argv[++i];
    if (arg == "--chip") {
      o.chip = value;
    } else if (arg == "--sim-dir") {
      o.sim_dir = value;
    } else if (arg == "--label") {
      o.label = value;
    } else if (arg == "--drdy") {
      o.drdy = value;
    } else if (arg == "--es") {
      o.es = value;
    } else if (arg == "--edge-gap-ms") {
      if (!parse_number(arg, value, 10000, o.edge_gap_ms)) return false;
    } else if (arg == "--drdy-offset" || arg == "--es-offset") {
      if (!parse_number(arg, value, 1023, arg == "--es-offset" ? o.es_offset : o.drdy_offset)) return false;
    } else {
      std::fprintf(stderr, "gpiosim_check: unknown option %s\n", arg.c_str());
      return false;
    }
  }
  if (o.chip.empty() || o.sim_dir.empty()) {
    std::fputs("gpiosim_check: --chip and --sim-dir are required\n", stderr);
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) {
    usage();
    return 2;
  }
  std::printf("gpiosim_check: %s, chip %s (%s)\n", GpiodLine::library_version().c_str(), o.chip.c_str(), o.sim_dir.c_str());
  SimLine drdy_pin(o.sim_dir, o.drdy_offset);
  SimLine es_pin(o.sim_dir, o.es_offset);
  if (!drdy_pin.set_pull(false)) {
    std::fprintf(stderr, "gpiosim_check: cannot write %s/pull: %s\n", drdy_pin.dir().c_str(), std::strerror(errno));
    return 2;
  }

  check_lookup(o);
  auto drdy = open_or_report("gpio-drdy-edge",
                             {.chip = o.chip, .line = o.drdy, .mode = GpioMode::edge_events, .edge = Edge::falling});
  std::unique_ptr<GpiodLine> es;
  if (drdy) {
    EdgeDriver pin(drdy_pin, o.edge_gap_ms * 1e-3);
    check_single_edge(*drdy, pin);
    check_timeout(*drdy, pin);
    check_conversions(*drdy, pin);
    check_queue(*drdy, pin);
    check_discard(*drdy, pin);
  }
  check_es(o, es_pin, es);
  if (drdy && es) check_consumers(o);
  return failures == 0 ? 0 : 1;
}
