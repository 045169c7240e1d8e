#pragma once

#include <array>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "gyrotc/hal/sim/sim_ds18b20.hpp"

// DS18B20s on a w1 bus as the kernel's w1 core and w1_therm show them under
// /sys/bus/w1/devices (Linux 5.10 and later; drivers/w1/slaves/w1_therm.c):
//
//  - reading w1_slave or temperature converts: the read returns after the
//    conversion time of the part's resolution (750 ms at 12 bits, 95 ms at 9),
//    with the scratchpad read back and its CRC checked;
//  - a scratchpad read that fails its CRC is read again, up to 5 times; if
//    every one fails the file reads empty (w1_therm returns 0 bytes on any
//    error: no "crc=.. NO" line reaches user space from these kernels);
//  - a part that does not answer the reset (unplugged) reads empty at once
//    (5 resets, no conversion); the master's search, every 10 s, removes its
//    folder after 10 searches without it, and brings it back at the first
//    search that finds it again;
//  - all-zero scratchpad (the bus held low): "00 .. : crc=00 YES", t=0;
//  - the 85 C power-on value: once, when a conversion did not happen;
//  - resolution reads the configuration byte ("12"), or the error code
//    ("-19") when the scratchpad cannot be read.
//
// The folder also has name, ext_power ("1": externally powered, so two
// sensors convert at once: w1_therm releases the bus while it waits),
// conv_time, features and alarms. Times are the emulator's clock (s); the
// FUSE layer (emu/fuse/w1_filesystem.cpp) replies when a read is ready.
namespace gyrotc::emu {

enum class W1Attribute : std::uint8_t { w1_slave, temperature, resolution, ext_power, conv_time, features, alarms, name };
inline constexpr std::array<W1Attribute, 8> kW1Attributes{W1Attribute::w1_slave,  W1Attribute::temperature, W1Attribute::resolution,
                                               W1Attribute::ext_power, W1Attribute::conv_time,   W1Attribute::features,
                                               W1Attribute::alarms,    W1Attribute::name};
const char* to_string(W1Attribute attribute) noexcept;
std::optional<W1Attribute> w1_attribute_named(const std::string& name) noexcept;

// One read of one file: when it completes and what it returns.
struct W1Read {
  double ready_s = 0.0;
  int error = 0;        // an errno (the folder is gone), or 0
  std::string content;  // may be empty: w1_therm's answer to a failed conversion
};

struct W1BusOptions {
  double search_period_s = 10.0;  // the w1 master's search (w1_timeout)
  int slave_ttl = 10;             // searches without a part before its folder goes (w1_max_slave_ttl)
  double bus_time_s = 0.012;      // reset, match ROM and a 9-byte read at 15.4 kbit/s
};

class W1Bus {
 public:
  W1Bus(std::vector<std::string> ids, double start_temp_c, double now_s, const W1BusOptions& options = {});

  // The ids whose folder exists now, sorted.
  std::vector<std::string> listed(double now_s);
  bool exists(const std::string& id, double now_s);
  // A read of `file` of sensor `id` started at now_s.
  W1Read read(const std::string& id, W1Attribute file, double now_s);

  void set_temperature_c(const std::string& id, double temp_c);
  // Faults: disconnect (unplugged), crc_error (every scratchpad read fails),
  // stuck, power_on_reset (once), all_zero, low_resolution (9 bits); none.
  void set_fault(const std::string& id, hal::SimTempFault fault, double now_s);
  std::optional<hal::SimTempFault> fault(const std::string& id) const;
  const std::vector<std::string>& ids() const noexcept { return ids_; }

 private:
  struct Sensor {
    std::string id;
    double temp_c = 25.0;
    double stuck_c = 25.0;
    hal::SimTempFault fault = hal::SimTempFault::none;
    bool present = true;        // the folder exists
    double missing_since_s = 0;  // unplugged at
    std::array<std::uint8_t, 9> last_good{};  // w1_therm's family_data: the last scratchpad that passed
  };
  Sensor* find(const std::string& id);
  void update(Sensor& s, double now_s);  // the master's searches up to now
  double search_after(double t_s) const;

  std::vector<std::string> ids_;
  std::vector<Sensor> sensors_;
  W1BusOptions options_;
  double epoch_s_;
  mutable std::mutex mutex_;
};

}  // namespace gyrotc::emu
