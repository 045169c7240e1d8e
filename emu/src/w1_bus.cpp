#include "gyrotc/emu/w1_bus.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>

#include "gyrotc/hal/chips/ds18b20.hpp"

namespace gyrotc::emu {

namespace {

constexpr int kMaxTry = 5;             // W1_THERM_MAX_TRY
constexpr double kResetS = 0.00096;    // a reset with no presence pulse: 480 us low + 480 us wait

// w1_DS18B20_convert_time: the datasheet's maximum per resolution, in ms.
int conversion_ms(int resolution_bits) {
  switch (resolution_bits) {
    case 9: return 95;
    case 10: return 190;
    case 11: return 375;
    default: return 750;
  }
}

int resolution_of(const std::array<std::uint8_t, 9>& pad) { return 9 + ((pad[4] >> 5) & 3); }

// temperature_from_RAM for a DS18B20: the signed 1/16 C count, in m°C.
int milli_c_of(const std::array<std::uint8_t, 9>& pad) {
  return static_cast<std::int16_t>(pad[1] << 8 | pad[0]) * 1000 / 16;
}

std::string hex9(const std::array<std::uint8_t, 9>& pad) {
  char text[40];
  std::snprintf(text, sizeof text, "%02x %02x %02x %02x %02x %02x %02x %02x %02x ", pad[0], pad[1], pad[2], pad[3],
                pad[4], pad[5], pad[6], pad[7], pad[8]);
  return text;
}

std::string line(int value) { return std::to_string(value) + "\n"; }

}  // namespace

const char* to_string(W1Attribute attribute) noexcept {
  switch (attribute) {
    case W1Attribute::w1_slave: return "w1_slave";
    case W1Attribute::temperature: return "temperature";
    case W1Attribute::resolution: return "resolution";
    case W1Attribute::ext_power: return "ext_power";
    case W1Attribute::conv_time: return "conv_time";
    case W1Attribute::features: return "features";
    case W1Attribute::alarms: return "alarms";
    case W1Attribute::name: return "name";
  }
  return "?";
}

std::optional<W1Attribute> w1_attribute_named(const std::string& name) noexcept {
  for (const W1Attribute a : kW1Attributes) {
    if (name == to_string(a)) return a;
  }
  return std::nullopt;
}

W1Bus::W1Bus(std::vector<std::string> ids, double start_temp_c, double now_s, const W1BusOptions& options)
    : ids_(std::move(ids)), options_(options), epoch_s_(now_s) {
  std::sort(ids_.begin(), ids_.end());
  for (const std::string& id : ids_) {
    Sensor s;
    s.id = id;
    s.temp_c = start_temp_c;
    s.last_good = hal::SimDs18b20::scratchpad_for(start_temp_c);
    sensors_.push_back(s);
  }
}

W1Bus::Sensor* W1Bus::find(const std::string& id) {
  for (Sensor& s : sensors_) {
    if (s.id == id) return &s;
  }
  return nullptr;
}

double W1Bus::search_after(double t_s) const {
  const double k = std::floor((t_s - epoch_s_) / options_.search_period_s) + 1.0;
  return epoch_s_ + k * options_.search_period_s;
}

void W1Bus::update(Sensor& s, double now_s) {
  if (s.fault == hal::SimTempFault::disconnect) {
    // The slave_ttl-th search without it removes the folder.
    const double gone_s = search_after(s.missing_since_s) + (options_.slave_ttl - 1) * options_.search_period_s;
    if (s.present && now_s >= gone_s) s.present = false;
  } else if (!s.present && now_s >= search_after(s.missing_since_s)) {
    s.present = true;  // found again by a search (missing_since_s holds the reconnection time)
  }
}

std::vector<std::string> W1Bus::listed(double now_s) {
  const std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  for (Sensor& s : sensors_) {
    update(s, now_s);
    if (s.present) out.push_back(s.id);
  }
  return out;
}

bool W1Bus::exists(const std::string& id, double now_s) {
  const std::lock_guard lock(mutex_);
  Sensor* s = find(id);
  if (s == nullptr) return false;
  update(*s, now_s);
  return s->present;
}

void W1Bus::set_temperature_c(const std::string& id, double temp_c) {
  const std::lock_guard lock(mutex_);
  if (Sensor* s = find(id)) s->temp_c = temp_c;
}

void W1Bus::set_fault(const std::string& id, hal::SimTempFault fault, double now_s) {
  const std::lock_guard lock(mutex_);
  Sensor* s = find(id);
  if (s == nullptr) return;
  update(*s, now_s);
  const bool was_unplugged = s->fault == hal::SimTempFault::disconnect;
  if (fault == hal::SimTempFault::disconnect && !was_unplugged) s->missing_since_s = now_s;
  if (fault != hal::SimTempFault::disconnect && was_unplugged) s->missing_since_s = now_s;  // plugged back in
  if (fault == hal::SimTempFault::stuck) s->stuck_c = s->temp_c;
  s->fault = fault;
}

std::optional<hal::SimTempFault> W1Bus::fault(const std::string& id) const {
  const std::lock_guard lock(mutex_);
  for (const Sensor& s : sensors_) {
    if (s.id == id) return s.fault;
  }
  return std::nullopt;
}

W1Read W1Bus::read(const std::string& id, W1Attribute attribute, double now_s) {
  const std::lock_guard lock(mutex_);
  Sensor* found = find(id);
  if (found == nullptr) return {now_s, ENOENT, {}};
  Sensor& s = *found;
  update(s, now_s);
  if (!s.present) return {now_s, ENODEV, {}};  // the attribute's device is gone
  const double bus_s = options_.bus_time_s;
  const bool unplugged = s.fault == hal::SimTempFault::disconnect;

  // The scratchpad as the part holds it now (a conversion's result).
  std::array<std::uint8_t, 9> pad{};
  switch (s.fault) {
    case hal::SimTempFault::stuck: pad = hal::SimDs18b20::scratchpad_for(s.stuck_c); break;
    case hal::SimTempFault::all_zero: pad = {}; break;
    case hal::SimTempFault::low_resolution: pad = hal::SimDs18b20::scratchpad_for(s.temp_c, 9); break;
    case hal::SimTempFault::power_on_reset: pad = hal::SimDs18b20::scratchpad_for(85.0); break;
    default: pad = hal::SimDs18b20::scratchpad_for(s.temp_c); break;
  }
  const int bits = resolution_of(pad);
  const double conversion_s = conversion_ms(bits) / 1000.0;

  switch (attribute) {
    case W1Attribute::w1_slave:
    case W1Attribute::temperature: {
      if (unplugged) return {now_s + kMaxTry * kResetS, 0, {}};  // no presence pulse: 5 resets, then empty
      if (s.fault == hal::SimTempFault::crc_error) {
        return {now_s + bus_s + conversion_s + kMaxTry * bus_s, 0, {}};  // 5 reads failed their CRC: empty
      }
      if (s.fault == hal::SimTempFault::power_on_reset) s.fault = hal::SimTempFault::none;  // once
      const double ready_s = now_s + bus_s + conversion_s + bus_s;
      s.last_good = pad;  // the CRC passed (an all-zero pad passes too)
      if (attribute == W1Attribute::temperature) return {ready_s, 0, line(milli_c_of(pad))};
      char crc[24];
      std::snprintf(crc, sizeof crc, ": crc=%02x YES\n", hal::crc8_maxim(std::span<const std::uint8_t>(pad.data(), 8)));
      return {ready_s, 0, hex9(pad) + crc + hex9(s.last_good) + "t=" + std::to_string(milli_c_of(pad)) + "\n"};
    }
    case W1Attribute::resolution:
      if (unplugged) return {now_s + kMaxTry * kResetS, 0, line(-ENODEV)};
      if (s.fault == hal::SimTempFault::crc_error) return {now_s + kMaxTry * bus_s, 0, line(-EIO)};
      return {now_s + bus_s, 0, line(bits)};
    case W1Attribute::ext_power:
      if (unplugged) return {now_s + kMaxTry * kResetS, 0, line(-ENODEV)};
      return {now_s + bus_s, 0, line(1)};
    case W1Attribute::conv_time: return {now_s, 0, line(conversion_ms(bits))};
    case W1Attribute::features: return {now_s, 0, line(0)};
    case W1Attribute::alarms: {
      // "TL TH" from scratchpad bytes 3 and 2 (0 0 when it cannot be read).
      const bool readable = !unplugged && s.fault != hal::SimTempFault::crc_error;
      const int tl = readable ? static_cast<std::int8_t>(pad[3]) : 0;
      const int th = readable ? static_cast<std::int8_t>(pad[2]) : 0;
      return {now_s + (readable ? bus_s : kMaxTry * kResetS), 0, std::to_string(tl) + " " + std::to_string(th) + "\n"};
    }
    case W1Attribute::name: return {now_s, 0, s.id + "\n"};
  }
  return {now_s, EINVAL, {}};
}

}  // namespace gyrotc::emu
