// The board configuration's GPIO lines as a gpio-sim device: the plan, and
// the configfs writes (on a folder that stands in for configfs).
#include "gyrotc/emu/gpio_sim.hpp"

#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

namespace {
hal::LinuxBoardConfig devices(const std::string& drdy_chip, const std::string& drdy_line) {
  hal::LinuxBoardConfig d;
  d.adc_drdy = {drdy_chip, drdy_line};
  d.opa548_es = {"gyrotc-emu", "ES"};
  d.opa548_es_sense = hal::GpioRef{"gyrotc-emu", "ES_SENSE", hal::GpioBias::pull_up, true};
  return d;
}
std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::string s;
  std::getline(in, s);
  return s;
}
}  // namespace

TEST_CASE("gpio-sim plan: lines named in the configuration get names and offsets on one bank per label") {
  const emu::GpioSimPlan plan = emu::plan_gpio_sim(devices("gyrotc-emu", "DRDY"));
  REQUIRE(plan.banks.size() == 1);
  CHECK(plan.banks[0].label == "gyrotc-emu");
  CHECK(plan.banks[0].num_lines == 3);
  CHECK(plan.drdy.offset == 0);
  CHECK(plan.es.offset == 1);
  REQUIRE(plan.es_sense);
  CHECK(plan.es_sense->offset == 2);
  CHECK(plan.es_sense->active_low);
}

TEST_CASE("gpio-sim plan: a line given by offset keeps it, and named lines follow it") {
  const emu::GpioSimPlan plan = emu::plan_gpio_sim(devices("gyrotc-emu", "5"));
  CHECK(plan.drdy.offset == 5);
  CHECK(plan.es.offset == 6);
  CHECK(plan.banks[0].num_lines == 8);
}

TEST_CASE("gpio-sim plan: a chip the kernel names (gpiochip0, a number, a path) is refused, naming the key") {
  for (const std::string chip : {"gpiochip0", "0", "/dev/gpiochip2"}) {
    try {
      (void)emu::plan_gpio_sim(devices(chip, "25"));
      FAIL("accepted " << chip);
    } catch (const app::InputError& e) {
      CHECK_THAT(e.what(), Catch::Contains("devices.adc.drdy"));
      CHECK_THAT(e.what(), Catch::Contains("label"));
    }
  }
}

TEST_CASE("gpio-sim plan: two signals on one line are refused") {
  hal::LinuxBoardConfig d = devices("gyrotc-emu", "ES");
  d.opa548_es_sense.reset();
  CHECK_THROWS_AS(emu::plan_gpio_sim(d), app::InputError);
}

TEST_CASE("gpio-sim device: the configfs folders and attributes of the plan, then live") {
  const std::filesystem::path root = std::filesystem::path(test::scratch_dir()) / "configfs-gpio-sim";
  std::filesystem::remove_all(root);
  const std::filesystem::path dev = root / "emu";
  std::filesystem::create_directories(dev / "bank0");
  // What the kernel would fill in once live.
  std::ofstream(dev / "dev_name") << "gpio-sim.0\n";
  std::ofstream(dev / "bank0" / "chip_name") << "gpiochip3\n";
  const emu::GpioSimPlan plan = emu::plan_gpio_sim(devices("gyrotc-emu", "DRDY"));
  emu::GpioSimDevice device(plan, "emu", root.string(), "/sys/devices/platform");
  CHECK(slurp(dev / "bank0" / "num_lines") == "3");
  CHECK(slurp(dev / "bank0" / "label") == "gyrotc-emu");
  CHECK(slurp(dev / "bank0" / "line0" / "name") == "DRDY");
  CHECK(slurp(dev / "bank0" / "line2" / "name") == "ES_SENSE");
  CHECK(slurp(dev / "live") == "1");
  CHECK(device.chip_name(0) == "gpiochip3");
  CHECK(device.line_dir(0, 1) == "/sys/devices/platform/gpio-sim.0/gpiochip3/sim_gpio1");
}

TEST_CASE("gpio-sim device: without the gpio-sim folder the error says which module to load") {
  const emu::GpioSimPlan plan = emu::plan_gpio_sim(devices("gyrotc-emu", "DRDY"));
  try {
    emu::GpioSimDevice device(plan, "emu", test::scratch_dir() + "/no-such-configfs");
    FAIL("no error");
  } catch (const app::RuntimeFailure& e) {
    CHECK_THAT(e.what(), Catch::Contains("modprobe gpio-sim"));
  }
}
