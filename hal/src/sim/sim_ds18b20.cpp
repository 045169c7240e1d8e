#include "gyrotc/hal/sim/sim_ds18b20.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "gyrotc/hal/chips/ds18b20.hpp"

namespace gyrotc::hal {

SimDs18b20::SimDs18b20(std::string id, double start_temp_c, Clock* sleep_clock)
    : id_(std::move(id)), sleep_clock_(sleep_clock), temp_c_(start_temp_c) {}

void SimDs18b20::set_fault(SimTempFault fault) noexcept {
  if (fault == SimTempFault::stuck) stuck_c_.store(temperature_c(), std::memory_order_relaxed);
  fault_.store(fault, std::memory_order_relaxed);
}

std::array<std::uint8_t, 9> SimDs18b20::scratchpad_for(double temp_c, int resolution_bits) noexcept {
  // Two's complement in 1/16 C, clamped to the part's -55..+125 C range; at
  // fewer than 12 bits the low bits are undefined (datasheet), here 0.
  const double step = std::ldexp(1.0, 12 - resolution_bits);  // in 1/16 C
  const double steps =
      std::clamp(std::nearbyint(temp_c * 16.0 / step) * step, -55.0 * 16.0, 125.0 * 16.0);
  const auto raw = static_cast<std::uint16_t>(static_cast<std::int16_t>(steps));
  // TH, TL (user bytes, power-on 0x4B 0x46), config (R1 R0 in bits 6..5:
  // 0x7F = 12 bit), reserved 0xFF, 0x0C, 0x10 as read from real parts.
  const auto config = static_cast<std::uint8_t>(0x1F | (resolution_bits - 9) << 5);
  std::array<std::uint8_t, 9> pad{static_cast<std::uint8_t>(raw & 0xFFu), static_cast<std::uint8_t>(raw >> 8),
                                  0x4B, 0x46, config, 0xFF, 0x0C, 0x10, 0};
  pad[8] = crc8_maxim(std::span<const std::uint8_t>(pad.data(), 8));
  return pad;
}

std::size_t SimDs18b20::render(W1File file, const std::array<std::uint8_t, 9>& pad, bool crc_ok,
                               std::span<char> out) noexcept {
  // w1_therm: t = (s16)(MSB << 8 | LSB) * 1000 / 16 in integer arithmetic.
  const int t_milli = static_cast<std::int16_t>(pad[1] << 8 | pad[0]) * 1000 / 16;
  int n = 0;
  if (file == W1File::resolution) {
    n = std::snprintf(out.data(), out.size(), "%d\n", 9 + ((pad[4] >> 5) & 3));
  } else if (file == W1File::temperature) {
    n = std::snprintf(out.data(), out.size(), "%d\n", t_milli);
  } else {
    n = std::snprintf(out.data(), out.size(),
                      "%02x %02x %02x %02x %02x %02x %02x %02x %02x : crc=%02x %s\n"
                      "%02x %02x %02x %02x %02x %02x %02x %02x %02x t=%d\n",
                      pad[0], pad[1], pad[2], pad[3], pad[4], pad[5], pad[6], pad[7], pad[8],
                      crc8_maxim(std::span<const std::uint8_t>(pad.data(), 8)), crc_ok ? "YES" : "NO", pad[0],
                      pad[1], pad[2], pad[3], pad[4], pad[5], pad[6], pad[7], pad[8], t_milli);
  }
  return n < 0 ? 0 : std::min(static_cast<std::size_t>(n), out.size() == 0 ? 0 : out.size() - 1);
}

bool SimDs18b20::current_pad(std::array<std::uint8_t, 9>& pad, bool consume) noexcept {
  switch (fault()) {
    case SimTempFault::none:
    case SimTempFault::disconnect: pad = scratchpad_for(temperature_c()); return true;
    case SimTempFault::stuck: pad = scratchpad_for(stuck_c_.load(std::memory_order_relaxed)); return true;
    case SimTempFault::crc_error:
      pad = scratchpad_for(temperature_c());
      pad[0] ^= 0x04;  // one bit flipped on the wire
      return false;
    case SimTempFault::power_on_reset:
      pad = scratchpad_for(85.0);  // datasheet: power-on value of the temperature register
      if (consume) {
        SimTempFault expected = SimTempFault::power_on_reset;
        fault_.compare_exchange_strong(expected, SimTempFault::none);
      }
      return true;
    case SimTempFault::all_zero: pad = {}; return true;
    case SimTempFault::low_resolution: pad = scratchpad_for(temperature_c(), 9); return true;
  }
  return true;
}

Result<std::size_t> SimDs18b20::do_read(W1File file, std::span<char> buffer) {
  std::array<std::uint8_t, 9> pad{};
  // The value is taken when the conversion starts.
  const bool crc_ok = current_pad(pad, true);
  if (sleep_clock_ != nullptr) sleep_clock_->sleep_until(sleep_clock_->now_s() + kConversionS);
  if (fault() == SimTempFault::disconnect) {
    return Error::make(ErrorCode::not_found, "w1 device '%s' vanished (simulated disconnect)", id_.c_str());
  }
  return render(file, pad, crc_ok, buffer);
}

void SimDs18b20::write_tree(const std::string& root) {
  const std::filesystem::path dir = std::filesystem::path(root) / id_;
  if (fault() == SimTempFault::disconnect) {
    std::filesystem::remove_all(dir);
    return;
  }
  std::filesystem::create_directories(dir);
  std::array<std::uint8_t, 9> pad{};
  const bool crc_ok = current_pad(pad, false);
  for (const W1File file : {W1File::w1_slave, W1File::temperature, W1File::resolution}) {
    std::array<char, 256> text{};
    const std::size_t n = render(file, pad, crc_ok, text);
    const char* name = file == W1File::w1_slave ? "w1_slave" : file == W1File::temperature ? "temperature" : "resolution";
    std::ofstream out(dir / name, std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(n));
    if (!out) throw std::runtime_error("cannot write the fake w1 tree under " + dir.string());
  }
}

}  // namespace gyrotc::hal
