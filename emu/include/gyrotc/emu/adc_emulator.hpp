#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <thread>

#include "gyrotc/emu/event_log.hpp"
#include "gyrotc/emu/pin_io.hpp"
#include "gyrotc/emu/spidev_endpoint.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/sim/sim_ads1251.hpp"

// The ADS1251 behind a spidev node and a GPIO line: the bit-level simulator
// (hal/sim/sim_ads1251.hpp) on the real clock, its DOUT/DRDY pin written to
// the line (gpio-sim's pull attribute) as it changes, so the kernel stamps
// and queues the edges as it would the part's. A thread of its own moves the
// pin at each conversion (run()); SPI frames come from the spidev node's
// thread. One mutex orders the two.
namespace gyrotc::emu {

class AdcEmulator final : public SpiTarget, hal::SimAds1251::PinListener {
 public:
  struct Stats {
    hal::SimAds1251::Counters chip;
    std::uint64_t corrupted_then_used = 0;  // a corrupted transfer the daemon followed with a rate-DAC frame
  };

  // pin_active_low: the board inverts the pin between the part and the SBC
  // (the configuration's drdy_active_low).
  AdcEmulator(hal::SimAds1251::Input& input, hal::Clock& clock, const hal::Ads1251Config& config, PinOutput& pin,
              bool pin_active_low, EventLog& log);
  ~AdcEmulator() override;
  AdcEmulator(const AdcEmulator&) = delete;
  AdcEmulator& operator=(const AdcEmulator&) = delete;

  // The pin thread (start/stop), or one step of it (tests, on a virtual clock):
  // moves the pin to now, returns when it next changes.
  void start();
  void stop();
  double step();

  int transfer(const SpiWire& wire, std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) override;

  // Faults (any thread): DRDY stays high; every transfer fails with EIO.
  void set_drdy_stall(bool on);
  void set_spi_error(bool on) { spi_error_.store(on); }
  // The rate DAC latched a frame: the sample of the last transfer was used.
  void note_sample_used();

  Stats stats() const;
  double sample_period_s() const noexcept { return chip_.sample_period_s(); }

 private:
  static constexpr double kSlowPinWriteS = 2e-3;  // a falling pin write logged as slow
  void on_pin_level(bool high, double t_s) noexcept override;
  void run();

  hal::Clock& clock_;
  PinOutput& pin_;
  bool pin_active_low_;
  EventLog& log_;
  mutable std::mutex mutex_;
  hal::SimAds1251 chip_;
  std::atomic<bool> spi_error_{false};
  std::atomic<bool> running_{false};
  std::thread thread_;
  bool last_transfer_corrupted_ = false;
  std::uint64_t corrupted_then_used_ = 0;
};

}  // namespace gyrotc::emu
