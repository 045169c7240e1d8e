#include "gyrotc/hal/linux/w1_sysfs.hpp"

#include <unistd.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/hal/chips/ds18b20.hpp"
#include "gyrotc/hal/sim/sim_ds18b20.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;
namespace fs = std::filesystem;

namespace {

// A fresh fake /sys/bus/w1/devices in a temp dir, removed afterwards.
struct FakeSysfs {
  fs::path root;
  FakeSysfs() {
    root = fs::temp_directory_path() / ("gyrotc-w1-" + std::to_string(::getpid()) + "-" +
                                        std::to_string(reinterpret_cast<std::uintptr_t>(this)));
    fs::remove_all(root);
    fs::create_directories(root);
    // The bus master is always there, as on a real system.
    fs::create_directories(root / "w1_bus_master1");
  }
  ~FakeSysfs() { fs::remove_all(root); }
  void write(const std::string& id, const std::string& file, const std::string& text) const {
    fs::create_directories(root / id);
    std::ofstream(root / id / file) << text;
  }
};

const char* kGood =
    "72 01 4b 46 7f ff 0e 10 57 : crc=57 YES\n"
    "72 01 4b 46 7f ff 0e 10 57 t=23125\n";

TemperatureReading read_once(const FakeSysfs& fake, const std::string& id = {},
                             W1File source = W1File::w1_slave) {
  W1Sysfs device{fake.root.string(), id};
  VirtualClock clock;
  Ds18b20 sensor{device, clock, {.source = source}};
  return sensor.read();
}

}  // namespace

TEST_CASE("a good w1_slave file in a sysfs tree reads as a valid temperature") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave", kGood);
  const auto reading = read_once(fake);
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(23.125));
}

TEST_CASE("crc=NO in sysfs is a CRC fault") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave",
             "72 01 4b 46 7f ff 0e 10 57 : crc=57 NO\n72 01 4b 46 7f ff 0e 10 57 t=23125\n");
  CHECK(read_once(fake).fault == TempFault::crc);
}

TEST_CASE("an empty w1_slave file is an empty read") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave", "");
  CHECK(read_once(fake).fault == TempFault::empty_read);
}

TEST_CASE("85000 at power-on in sysfs is the power-on value") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave",
             "50 05 4b 46 7f ff 0c 10 1c : crc=1c YES\n50 05 4b 46 7f ff 0c 10 1c t=85000\n");
  CHECK(read_once(fake).fault == TempFault::power_on_value);
}

TEST_CASE("garbage in w1_slave is a parse error") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave", "\x01\x02 not a w1 file\n\n");
  CHECK(read_once(fake).fault == TempFault::parse_error);
}

TEST_CASE("a missing device directory is a missing device, naming the path") {
  FakeSysfs fake;
  CHECK(read_once(fake).fault == TempFault::missing_device);
  CHECK(read_once(fake, "28-0000deadbeef").fault == TempFault::missing_device);
  W1Sysfs device{fake.root.string(), "28-0000deadbeef"};
  std::array<char, 64> buffer{};
  const auto n = device.read(W1File::w1_slave, buffer);
  REQUIRE_FALSE(n.ok());
  const std::string message(n.error().message());
  CHECK(message.find((fake.root / "28-0000deadbeef" / "w1_slave").string()) != std::string::npos);
  CHECK(message.find("No such file or directory") != std::string::npos);
}

TEST_CASE("a device directory that vanishes between reads becomes a missing device") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave", kGood);
  W1Sysfs device{fake.root.string()};
  VirtualClock clock;
  Ds18b20 sensor{device, clock, {}};
  REQUIRE(sensor.read().valid);
  fs::remove_all(fake.root / "28-000005e2fdc3");
  CHECK(sensor.read().fault == TempFault::missing_device);
}

TEST_CASE("without an id the only 28-* device is used, other families ignored") {
  FakeSysfs fake;
  fake.write("10-000801b5e8f4", "w1_slave", "garbage");  // a DS18S20, family 0x10
  fake.write("28-000005e2fdc3", "w1_slave", kGood);
  W1Sysfs device{fake.root.string()};
  CHECK(device.device_path() == (fake.root / "28-000005e2fdc3").string());
  CHECK(read_once(fake).valid);
}

TEST_CASE("without an id and with two DS18B20s no reading is taken from either, and the error names both") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave", kGood);
  fake.write("28-000009aaaaaa", "w1_slave", kGood);
  W1Sysfs device{fake.root.string()};
  CHECK(device.device_path() == (fake.root / "28-*").string());
  const Status bound = device.find_device();
  REQUIRE_FALSE(bound.ok());
  CHECK(std::string(bound.error().message()) == "2 DS18B20s under '" + fake.root.string() +
                                                    "' (28-000005e2fdc3, 28-000009aaaaaa) and no id configured: "
                                                    "which one is this sensor? set its id");
  CHECK(read_once(fake).fault == TempFault::ambiguous);
}

TEST_CASE("a DS18B20 converting at fewer than 12 bits is refused: its scratchpad says so") {
  FakeSysfs fake;
  SimDs18b20 chip{"28-00000000cafe", 55.3};
  chip.set_fault(SimTempFault::low_resolution);
  chip.write_tree(fake.root.string());
  CHECK(read_once(fake).fault == TempFault::resolution);
  chip.set_fault(SimTempFault::none);
  chip.write_tree(fake.root.string());
  CHECK(read_once(fake).valid);
}

TEST_CASE("with the temperature file the resolution is read from w1_therm's resolution file") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "temperature", "55312\n");
  fake.write("28-000005e2fdc3", "resolution", "9\n");
  CHECK(read_once(fake, {}, W1File::temperature).fault == TempFault::resolution);
  fake.write("28-000005e2fdc3", "resolution", "12\n");
  CHECK(read_once(fake, {}, W1File::temperature).valid);
  fs::remove(fake.root / "28-000005e2fdc3" / "resolution");  // kernels before 5.10: nothing to check
  CHECK(read_once(fake, {}, W1File::temperature).valid);
}

TEST_CASE("a device named by id is read even when others come first") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "w1_slave", "");
  fake.write("28-000009aaaaaa", "w1_slave", kGood);
  CHECK(read_once(fake, "28-000009aaaaaa").valid);
}

TEST_CASE("the temperature file can be the source") {
  FakeSysfs fake;
  fake.write("28-000005e2fdc3", "temperature", "-1062\n");
  const auto reading = read_once(fake, {}, W1File::temperature);
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(-1.062));
}

TEST_CASE("a tree generated by the DS18B20 simulator reads back through W1Sysfs") {
  FakeSysfs fake;
  SimDs18b20 chip{"28-00000000cafe", 55.3};
  chip.write_tree(fake.root.string());
  auto reading = read_once(fake);
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(55.3125));
  reading = read_once(fake, {}, W1File::temperature);
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(55.312));  // the kernel's integer millidegrees
  chip.set_fault(SimTempFault::crc_error);
  chip.write_tree(fake.root.string());
  CHECK(read_once(fake).fault == TempFault::crc);
  chip.set_fault(SimTempFault::disconnect);
  chip.write_tree(fake.root.string());
  CHECK(read_once(fake).fault == TempFault::missing_device);
}
