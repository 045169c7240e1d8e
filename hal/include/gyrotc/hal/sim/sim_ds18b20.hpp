#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <string>

#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/w1_device.hpp"

namespace gyrotc::hal {

enum class SimTempFault : std::uint8_t {
  none,
  disconnect,      // the device directory vanishes
  crc_error,       // a corrupted scratchpad byte; the kernel reports crc=.. NO
  stuck,           // the value freezes at the temperature when the fault was set
  power_on_reset,  // the next read shows the 85.000 C power-on scratchpad (once)
  all_zero,        // the bus is held low: all-zero scratchpad, "crc=00 YES", t=0
  low_resolution,  // configured for 9 bits (0.5 C steps), as a part set up elsewhere may be
};

// DS18B20 + w1_therm simulator: renders the w1_slave, temperature and
// resolution files in the kernel's format from a 12-bit scratchpad (1/16 C
// steps; 9 bits with the low_resolution fault) of the
// published temperature. Thread model: set_temperature_c() is called by the
// thread that steps the plant, read() by the sensor thread; they share only
// atomics. With a sleep clock, read() takes conversion_s as the real part
// does (the real-time mode); without, it returns at once (lockstep: the
// runner schedules conversions itself).
class SimDs18b20 final : public W1Device {
 public:
  static constexpr double kConversionS = 0.75;  // datasheet: 12-bit conversion, max

  explicit SimDs18b20(std::string id = "28-00000000sim0", double start_temp_c = 25.0,
                      Clock* sleep_clock = nullptr);

  void set_temperature_c(double temp_c) noexcept { temp_c_.store(temp_c, std::memory_order_relaxed); }
  double temperature_c() const noexcept { return temp_c_.load(std::memory_order_relaxed); }
  // Fault injection (any thread).
  void set_fault(SimTempFault fault) noexcept;
  SimTempFault fault() const noexcept { return fault_.load(std::memory_order_relaxed); }

  // The 9 scratchpad bytes for a temperature (CRC in byte 8).
  static std::array<std::uint8_t, 9> scratchpad_for(double temp_c, int resolution_bits = 12) noexcept;
  // The file as w1_therm prints it for a scratchpad.
  static std::size_t render(W1File file, const std::array<std::uint8_t, 9>& pad, bool crc_ok,
                            std::span<char> out) noexcept;
  // Writes <root>/<id>/{w1_slave,temperature,resolution} for the current state (a fake
  // sysfs tree for W1Sysfs); throws std::runtime_error on failure.
  void write_tree(const std::string& root);
  const std::string& id() const noexcept { return id_; }

 private:
  Result<std::size_t> do_read(W1File file, std::span<char> buffer) override;
  std::string_view do_name() const noexcept override { return id_; }
  // The scratchpad and kernel CRC verdict the next read shows (consumes a
  // one-shot power-on fault when consume is true).
  bool current_pad(std::array<std::uint8_t, 9>& pad, bool consume) noexcept;

  std::string id_;
  Clock* sleep_clock_;
  std::atomic<double> temp_c_;
  std::atomic<double> stuck_c_{0.0};
  std::atomic<SimTempFault> fault_{SimTempFault::none};
};

}  // namespace gyrotc::hal
