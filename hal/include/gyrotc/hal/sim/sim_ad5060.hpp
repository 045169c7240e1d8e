#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "gyrotc/hal/chips/ad5060.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// Bit-level AD5060 simulator: decodes 24-bit frames (6 don't-care bits,
// PD1 PD0, 16 data bits) clocked in on the SCLK falling edges. A frame that
// is not 24 bits long is ignored, as the part ignores a SYNC that rises
// early. In power-down the output is pulled to 0 V (1 kOhm / 100 kOhm) or
// left open (three-state, reported as 0 V).
//
// SPI modes: in modes 1, 2 and 3 the data is stable at the falling edges the
// part latches on. In mode 0 the controller changes the data at those very
// edges: the race with the part's hold time (t6, 4.5 ns) goes the part's
// worst way, every bit latched is the next one and the frame arrives shifted
// left by one (its last bit the idle data line, low). SCLK above the part's
// 30 MHz (t1 = 33 ns) loses the frame: it is ignored.
class SimAd5060 final : public SpiBus {
 public:
  // Told on every accepted frame, on the thread that wrote it.
  class Listener {
   public:
    virtual ~Listener() = default;
    virtual void on_dac_output(double output_v, Ad5060PowerDown mode) noexcept = 0;
  };

  SimAd5060(std::string name, double vref_v, Listener* listener = nullptr)
      : name_(std::move(name)), v_per_code_(vref_v / 65536.0), listener_(listener) {}

  // Power-on state: code 0 in normal mode (the zero-scale part variant).
  double output_v() const noexcept { return output_v_.load(std::memory_order_relaxed); }
  std::uint16_t code() const noexcept { return code_; }
  Ad5060PowerDown mode() const noexcept { return mode_; }
  std::uint64_t frames() const noexcept { return frames_; }
  std::uint64_t ignored_frames() const noexcept { return ignored_frames_; }
  // Fault injection (any thread): every transfer fails as a broken SPI
  // controller's does (EIO), and the part keeps its last code.
  void set_spi_error(bool on) noexcept { spi_error_.store(on, std::memory_order_relaxed); }

 private:
  Status do_configure(const SpiConfig& config) noexcept override;
  Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept override;
  std::string_view do_name() const noexcept override { return name_; }

  std::string name_;
  double v_per_code_;
  Listener* listener_;
  bool configured_ = false;
  std::uint8_t spi_mode_ = 1;
  std::uint32_t speed_hz_ = 0;
  std::uint16_t code_ = 0;
  Ad5060PowerDown mode_ = Ad5060PowerDown::normal;
  std::atomic<double> output_v_{0.0};
  std::atomic<bool> spi_error_{false};
  std::uint64_t frames_ = 0;
  std::uint64_t ignored_frames_ = 0;
};

}  // namespace gyrotc::hal
