#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "gyrotc/hal/gpio_line.hpp"

namespace gyrotc::hal {

enum class GpioMode : std::uint8_t {
  output,       // set(); get() reads the line back
  input,        // get()
  edge_events,  // wait_edge() on the one edge requested (GpiodLineSpec::edge); get()
};

// The pull of the line's pin, as the kernel's bias flags (needs a driver
// that supports it: the Raspberry Pi's does).
enum class GpioBias : std::uint8_t { as_is, disabled, pull_up, pull_down };

struct GpiodLineSpec {
  std::string chip;  // name ("gpiochip0"), path ("/dev/gpiochip0"), label or number
  std::string line;  // line name ("DRDY") or offset ("17")
  GpioMode mode = GpioMode::input;
  // edge_events only: the one edge the kernel is asked to report. Only that
  // edge is requested because with both edges the kernel labels an event by
  // reading the level in its IRQ thread: a pulse shorter than that latency
  // (the ADS1251's 6 tCLK DRDY pulse) is over by then and comes out as the
  // wrong edge.
  Edge edge = Edge::falling;
  GpioBias bias = GpioBias::as_is;
  bool active_low = false;    // levels (and edges) are logical: inverted on the pin
  bool open_drain = false;    // outputs only
  bool initial_high = false;  // outputs only: the level at request time
};

// One line through libgpiod, consumer "gyrotc": the 1.6 API (Debian 12,
// gpiod_line_request_*) or the 2.x API (Debian 13, Yocto scarthgap and later:
// gpiod_chip_request_lines), whichever was found at configure time; both
// implement the same contract. Edge events carry CLOCK_MONOTONIC time stamps.
// Errors name the chip and line and carry the errno text.
class GpiodLine final : public GpioLine {
 public:
  static constexpr const char* kConsumer = "gyrotc";

  static Result<std::unique_ptr<GpiodLine>> open(const GpiodLineSpec& spec) noexcept;
  // "libgpiod 1.6.3" or "libgpiod 2.2.1": the library the binary runs with.
  static std::string library_version();
  ~GpiodLine() override;  // releases the line
  GpiodLine(const GpiodLine&) = delete;
  GpiodLine& operator=(const GpiodLine&) = delete;

 private:
  struct Handles;  // the libgpiod objects of the API version built against

  GpiodLine(std::string name, const GpiodLineSpec& spec, std::unique_ptr<Handles> handles) noexcept;

  Status do_set(bool high) noexcept override;
  Result<bool> do_get() noexcept override;
  Result<double> do_wait_edge(Edge edge, double timeout_s) noexcept override;
  Result<int> do_discard_edges() noexcept override;
  std::string_view do_name() const noexcept override { return name_; }

  // Checks shared by both back-ends.
  Status check_settable() const noexcept;
  Status check_edge(Edge edge) const noexcept;

  std::string name_;
  GpioMode mode_;
  Edge edge_;
  std::unique_ptr<Handles> handles_;
};

}  // namespace gyrotc::hal
