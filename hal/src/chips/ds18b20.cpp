#include "gyrotc/hal/chips/ds18b20.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace gyrotc::hal {

std::uint8_t crc8_maxim(std::span<const std::uint8_t> bytes) noexcept {
  std::uint8_t crc = 0;
  for (std::uint8_t byte : bytes) {
    for (int bit = 0; bit < 8; ++bit) {
      const bool mix = ((crc ^ byte) & 1u) != 0;
      crc = static_cast<std::uint8_t>(crc >> 1);
      if (mix) crc ^= 0x8C;
      byte = static_cast<std::uint8_t>(byte >> 1);
    }
  }
  return crc;
}

namespace {

Error bad(const char* what) noexcept { return Error::make(ErrorCode::bad_data, "w1_slave: %s", what); }

void skip_spaces(std::string_view& s) noexcept {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
}

bool hex_byte(std::string_view& s, std::uint8_t& out) noexcept {
  skip_spaces(s);
  if (s.size() < 2) return false;
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + 2, value, 16);
  if (ec != std::errc{} || end != s.data() + 2) return false;
  out = static_cast<std::uint8_t>(value);
  s.remove_prefix(2);
  return true;
}

bool consume(std::string_view& s, std::string_view token) noexcept {
  skip_spaces(s);
  if (s.substr(0, token.size()) != token) return false;
  s.remove_prefix(token.size());
  return true;
}

bool integer(std::string_view& s, std::int32_t& out) noexcept {
  skip_spaces(s);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  if (ec != std::errc{}) return false;
  s.remove_prefix(static_cast<std::size_t>(end - s.data()));
  return true;
}

bool only_space_left(std::string_view s) noexcept {
  return std::all_of(s.begin(), s.end(), [](char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; });
}

}  // namespace

Result<W1Slave> parse_w1_slave(std::string_view text) noexcept {
  const std::size_t newline = text.find('\n');
  if (newline == std::string_view::npos) return bad("expected two lines");
  std::string_view first = text.substr(0, newline);
  std::string_view second = text.substr(newline + 1);

  W1Slave out;
  for (std::uint8_t& byte : out.scratchpad) {
    if (!hex_byte(first, byte)) return bad("first line: expected 9 hex bytes");
  }
  std::uint8_t crc = 0;
  if (!consume(first, ":") || !consume(first, "crc=") || !hex_byte(first, crc)) {
    return bad("first line: expected ': crc=xx'");
  }
  if (consume(first, "YES")) {
    out.kernel_crc_ok = true;
  } else if (!consume(first, "NO")) {
    return bad("first line: expected YES or NO after crc");
  }
  std::uint8_t byte = 0;
  for (int i = 0; i < 9; ++i) {
    if (!hex_byte(second, byte)) return bad("second line: expected 9 hex bytes");
  }
  if (!consume(second, "t=") || !integer(second, out.t_milli_c) || !only_space_left(second)) {
    return bad("second line: expected 't=<millidegrees>'");
  }
  return out;
}

Result<std::int32_t> parse_temperature_file(std::string_view text) noexcept {
  std::int32_t milli_c = 0;
  if (!integer(text, milli_c) || !only_space_left(text)) {
    return Error::make(ErrorCode::bad_data, "temperature: expected one integer in millidegrees");
  }
  return milli_c;
}

Ds18b20::Ds18b20(W1Device& device, Clock& clock, const Ds18b20Options& options)
    : device_(device), clock_(clock), options_(options) {}

namespace {
TemperatureReading failed(TempFault fault, double time_s, double temp_c = 0.0) noexcept {
  return {.temp_c = temp_c, .time_s = time_s, .valid = false, .fault = fault};
}
}  // namespace

TemperatureReading Ds18b20::evaluate(std::string_view text, double time_s) noexcept {
  if (only_space_left(text)) return failed(TempFault::empty_read, time_s);
  if (options_.source == W1File::temperature) {
    const Result<std::int32_t> milli_c = parse_temperature_file(text);
    if (!milli_c) return failed(TempFault::parse_error, time_s);
    return accept(*milli_c, time_s);
  }
  const Result<W1Slave> slave = parse_w1_slave(text);
  if (!slave) return failed(TempFault::parse_error, time_s);
  const auto& pad = slave->scratchpad;
  if (std::all_of(pad.begin(), pad.end(), [](std::uint8_t b) { return b == 0; })) {
    return failed(TempFault::all_zero, time_s);
  }
  if (!slave->kernel_crc_ok || crc8_maxim(pad) != 0) return failed(TempFault::crc, time_s);
  // Configuration register R1 R0 (bits 6..5): 9 + R bits; the 750 ms
  // conversion and the loop's 1/16 C steps are those of 12 bits.
  if (9 + ((pad[4] >> 5) & 3) != kResolutionBits) return failed(TempFault::resolution, time_s);
  return accept(slave->t_milli_c, time_s);
}

TemperatureReading Ds18b20::accept(std::int32_t milli_c, double time_s) noexcept {
  const double temp_c = milli_c / 1000.0;
  if (milli_c == kPowerOnMilliC &&
      !(have_previous_ && std::abs(previous_milli_c_ / 1000.0 - 85.0) <= kNear85C)) {
    return failed(TempFault::power_on_value, time_s, temp_c);
  }
  if (temp_c < options_.min_c || temp_c > options_.max_c) {
    return failed(TempFault::out_of_range, time_s, temp_c);
  }
  if (!have_previous_ || milli_c != previous_milli_c_) {
    have_previous_ = true;
    previous_milli_c_ = milli_c;
    unchanged_since_s_ = time_s;
  } else if (options_.stuck_after_s > 0.0 && time_s - unchanged_since_s_ > options_.stuck_after_s) {
    return failed(TempFault::stuck, time_s, temp_c);
  }
  return {.temp_c = temp_c, .time_s = time_s, .valid = true, .fault = TempFault::none};
}

TemperatureReading Ds18b20::do_read() {
  const double start_s = clock_.now_s();
  std::array<char, 256> buffer{};
  const Result<std::size_t> n = device_.read(options_.source, buffer);
  if (!n) {
    resolution_checked_ = false;  // a device that comes back may be another part
    switch (n.error().code()) {
      case ErrorCode::not_found: return failed(TempFault::missing_device, start_s);
      case ErrorCode::invalid_config: return failed(TempFault::ambiguous, start_s);
      default: return failed(TempFault::io_error, start_s);
    }
  }
  const TemperatureReading reading = evaluate(std::string_view(buffer.data(), *n), start_s);
  if (options_.source != W1File::temperature) return reading;
  // A part that was reset (the 85 C power-on value) has reloaded its
  // resolution from its EEPROM.
  if (reading.fault == TempFault::power_on_value) resolution_checked_ = false;
  // An all-zero scratchpad (the bus held low) passes w1_therm's CRC and reads
  // 0 millidegrees, which is also a temperature: its configuration byte (zero:
  // 9 bits) tells them apart.
  const bool zero = reading.valid && reading.temp_c == 0.0;
  if (reading.valid && (!resolution_checked_ || zero)) {
    // The temperature file has no scratchpad: ask w1_therm (Linux >= 5.10;
    // without the file there is nothing to check).
    if (const Result<std::size_t> r = device_.read(W1File::resolution, buffer)) {
      const Result<std::int32_t> bits = parse_temperature_file(std::string_view(buffer.data(), *r));  // one integer
      if (bits && *bits != kResolutionBits) {
        return failed(zero ? TempFault::all_zero : TempFault::resolution, start_s, reading.temp_c);
      }
    }
    resolution_checked_ = true;
  }
  return reading;
}

}  // namespace gyrotc::hal
