// The emulated w1 bus: what a reader of the w1_therm attributes sees, and
// when, as Linux 5.10+ shows it; and what the production DS18B20 driver makes
// of it.
#include "gyrotc/emu/w1_bus.hpp"

#include <algorithm>
#include <cerrno>
#include <string>

#include "gyrotc/hal/chips/ds18b20.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {
const std::string kId = "28-0000061a2b3c";

// The driver's W1Device over the bus, read at the clock's time; the clock
// moves to the read's completion, as a blocking read of sysfs would.
class BusDevice final : public hal::W1Device {
 public:
  BusDevice(emu::W1Bus& bus, hal::VirtualClock& clock) : bus_(bus), clock_(clock) {}

 private:
  hal::Result<std::size_t> do_read(hal::W1File file, std::span<char> buffer) override {
    const emu::W1Attribute a = file == hal::W1File::w1_slave      ? emu::W1Attribute::w1_slave
                               : file == hal::W1File::temperature ? emu::W1Attribute::temperature
                                                                  : emu::W1Attribute::resolution;
    const emu::W1Read r = bus_.read(kId, a, clock_.now_s());
    clock_.sleep_until(r.ready_s);
    if (r.error != 0) return hal::Error::from_errno(r.error, "cannot read", kId);
    const std::size_t n = std::min(buffer.size(), r.content.size());
    std::copy_n(r.content.begin(), n, buffer.begin());
    return n;
  }
  std::string_view do_name() const noexcept override { return kId; }
  emu::W1Bus& bus_;
  hal::VirtualClock& clock_;
};
}  // namespace

TEST_CASE("emulated w1: reading w1_slave converts for 750 ms and shows the kernel's two lines, CRC checked") {
  emu::W1Bus bus({kId}, 25.0, 0.0);
  bus.set_temperature_c(kId, 54.9375);
  const emu::W1Read r = bus.read(kId, emu::W1Attribute::w1_slave, 10.0);
  CHECK(r.ready_s - 10.0 == Approx(0.750 + 2 * 0.012));
  const auto slave = hal::parse_w1_slave(r.content);
  REQUIRE(slave.ok());
  CHECK(slave->kernel_crc_ok);
  CHECK(slave->t_milli_c == 54937);
  CHECK(r.content.find(": crc=") != std::string::npos);
}

TEST_CASE("emulated w1: a scratchpad that fails its CRC on every read leaves w1_slave empty, after the conversion") {
  emu::W1Bus bus({kId}, 25.0, 0.0);
  bus.set_fault(kId, hal::SimTempFault::crc_error, 0.0);
  const emu::W1Read r = bus.read(kId, emu::W1Attribute::w1_slave, 1.0);
  CHECK(r.error == 0);
  CHECK(r.content.empty());  // w1_therm returns 0 bytes after 5 bad reads; no "crc=.. NO" line
  CHECK(r.ready_s - 1.0 > 0.750);
  CHECK(bus.read(kId, emu::W1Attribute::resolution, 2.0).content == "-5\n");  // -EIO
}

TEST_CASE("emulated w1: an unplugged sensor reads empty at once, and its folder goes at the 10th search without it") {
  emu::W1Bus bus({kId}, 25.0, 0.0);
  bus.set_fault(kId, hal::SimTempFault::disconnect, 3.0);
  const emu::W1Read r = bus.read(kId, emu::W1Attribute::w1_slave, 4.0);
  CHECK(r.content.empty());
  CHECK(r.ready_s - 4.0 < 0.01);  // no presence pulse: no conversion
  CHECK(bus.exists(kId, 99.0));   // searches at 10, 20, ... 90 s: nine without it
  CHECK_FALSE(bus.exists(kId, 100.0));
  CHECK(bus.listed(100.0).empty());
  CHECK(bus.read(kId, emu::W1Attribute::w1_slave, 101.0).error == ENODEV);
}

TEST_CASE("emulated w1: a sensor plugged back in reappears at the next search and reads again") {
  emu::W1Bus bus({kId}, 25.0, 0.0);
  bus.set_fault(kId, hal::SimTempFault::disconnect, 3.0);
  CHECK_FALSE(bus.exists(kId, 150.0));
  bus.set_fault(kId, hal::SimTempFault::none, 152.0);
  CHECK_FALSE(bus.exists(kId, 159.0));
  CHECK(bus.exists(kId, 160.0));
  CHECK_FALSE(bus.read(kId, emu::W1Attribute::w1_slave, 161.0).content.empty());
}

TEST_CASE("emulated w1: the 85 C power-on value shows once, then conversions are right again") {
  emu::W1Bus bus({kId}, 40.0, 0.0);
  bus.set_fault(kId, hal::SimTempFault::power_on_reset, 0.0);
  CHECK(bus.read(kId, emu::W1Attribute::temperature, 1.0).content == "85000\n");
  CHECK(bus.read(kId, emu::W1Attribute::temperature, 2.0).content == "40000\n");
}

TEST_CASE("emulated w1: a part set to 9 bits converts in 95 ms and says 9 in its resolution attribute") {
  emu::W1Bus bus({kId}, 40.0, 0.0);
  bus.set_fault(kId, hal::SimTempFault::low_resolution, 0.0);
  const emu::W1Read r = bus.read(kId, emu::W1Attribute::w1_slave, 1.0);
  CHECK(r.ready_s - 1.0 == Approx(0.095 + 2 * 0.012));
  CHECK(bus.read(kId, emu::W1Attribute::resolution, 2.0).content == "9\n");
  CHECK(bus.read(kId, emu::W1Attribute::conv_time, 2.0).content == "95\n");
}

TEST_CASE("emulated w1: the DS18B20 driver reads a good value, and an empty read or a vanished folder as faults") {
  hal::VirtualClock clock(1.0);
  emu::W1Bus bus({kId}, 55.0, 0.0);
  BusDevice device(bus, clock);
  hal::Ds18b20 sensor(device, clock, {});
  const hal::TemperatureReading good = sensor.read();
  CHECK(good.valid);
  CHECK(good.temp_c == Approx(55.0));
  bus.set_fault(kId, hal::SimTempFault::crc_error, clock.now_s());
  const hal::TemperatureReading crc = sensor.read();
  CHECK_FALSE(crc.valid);
  CHECK(crc.fault == hal::TempFault::empty_read);
  bus.set_fault(kId, hal::SimTempFault::disconnect, clock.now_s());
  clock.sleep_until(clock.now_s() + 200.0);
  const hal::TemperatureReading gone = sensor.read();
  CHECK_FALSE(gone.valid);
  CHECK(gone.fault == hal::TempFault::io_error);  // ENODEV on the attribute of a removed device
}

TEST_CASE("emulated w1: two sensors on one bus list sorted, with the names asked for") {
  emu::W1Bus bus({"28-000005e2fdc3", kId}, 25.0, 0.0);
  const auto ids = bus.listed(0.0);
  REQUIRE(ids.size() == 2);
  CHECK(ids[0] == "28-000005e2fdc3");
  CHECK(bus.read(kId, emu::W1Attribute::name, 0.0).content == kId + "\n");
  CHECK(bus.read("28-ffffffffffff", emu::W1Attribute::w1_slave, 0.0).error == ENOENT);
}
