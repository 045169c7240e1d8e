#pragma once

#include <memory>
#include <string>
#include <utility>

#include "gyrotc/hal/gpio_line.hpp"

struct gpiod_chip;
struct gpiod_line;

namespace gyrotc::hal {

enum class GpioMode : std::uint8_t {
  output,       // set(); get() reads the line back
  input,        // get()
  edge_events,  // wait_edge() on both edges; get()
};

struct GpiodLineSpec {
  std::string chip;  // name ("gpiochip0"), path ("/dev/gpiochip0"), label or number
  std::string line;  // line name ("DRDY") or offset ("17")
  GpioMode mode = GpioMode::input;
  bool open_drain = false;    // outputs only
  bool initial_high = false;  // outputs only: the level at request time
};

// One line through libgpiod 1.6 (consumer "gyrotc"). Errors name the chip
// and line and carry the errno text.
class GpiodLine final : public GpioLine {
 public:
  static constexpr const char* kConsumer = "gyrotc";

  static Result<std::unique_ptr<GpiodLine>> open(const GpiodLineSpec& spec) noexcept;
  ~GpiodLine() override;
  GpiodLine(const GpiodLine&) = delete;
  GpiodLine& operator=(const GpiodLine&) = delete;

 private:
  GpiodLine(std::string name, GpioMode mode, gpiod_chip* chip, gpiod_line* line) noexcept
      : name_(std::move(name)), mode_(mode), chip_(chip), line_(line) {}

  Status do_set(bool high) noexcept override;
  Result<bool> do_get() noexcept override;
  Result<double> do_wait_edge(Edge edge, double timeout_s) noexcept override;
  Result<int> do_discard_edges() noexcept override;
  std::string_view do_name() const noexcept override { return name_; }

  std::string name_;
  GpioMode mode_;
  gpiod_chip* chip_;
  gpiod_line* line_;
};

}  // namespace gyrotc::hal
