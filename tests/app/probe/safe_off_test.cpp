// `gyrotc safe-off` on hal = "linux" without a board: what it opens and what
// it reports. (Its success path needs a GPIO chip for the E/S line.)
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/session.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::app;
namespace fs = std::filesystem;

namespace {

DaemonConfig linux_config(const std::string& tec_spi, const std::string& rate_spi) {
  const std::string text = "hal = \"linux\"\n"
                           "[devices.adc]\nspi = \"/dev/spidev-gyrotc-missing0.0\"\n"
                           "[devices.rate_dac]\nspi = \"" + rate_spi + "\"\n"
                           "[devices.tec_dac]\nspi = \"" + tec_spi + "\"\n"
                           "[devices.opa548]\nes = \"gpiochip-gyrotc-missing:24\"\n"
                           "[devices.casing_sensor]\nw1_root = \"/nonexistent-gyrotc-w1\"\n";
  return parse_daemon_config(toml::parse(text), "safe-off.toml");
}

std::string failure_of(const DaemonConfig& config) {
  try {
    safe_off_board(config);
  } catch (const RuntimeFailure& e) {
    return e.what();
  }
  return {};
}

}  // namespace

TEST_CASE("safe-off reports the TEC path only: a missing sensor or ADC is not its business") {
  const std::string m = failure_of(linux_config("/dev/spidev-gyrotc-missing6.1", "/dev/spidev-gyrotc-missing6.0"));
  INFO(m);
  CHECK(m.find("safe-off: the TEC is not known to be safe: TEC DAC: cannot open spidev "
               "'/dev/spidev-gyrotc-missing6.1'") == 0);
  CHECK(m.find("OPA548 E/S: cannot open gpiochip 'gpiochip-gyrotc-missing'") != std::string::npos);
  CHECK(m.find("w1") == std::string::npos);
  CHECK(m.find("spidev-gyrotc-missing0.0") == std::string::npos);  // the ADC was not opened
}

TEST_CASE("safe-off leaves a board another process holds alone, naming the holder") {
  const std::string dir = fs::temp_directory_path() / ("gyrotc-safe-off-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir + "/tec") << "";
  std::ofstream(dir + "/rate") << "";
  const int holder = ::open((dir + "/tec").c_str(), O_RDWR | O_CLOEXEC);
  REQUIRE(holder >= 0);
  REQUIRE(::flock(holder, LOCK_EX | LOCK_NB) == 0);
  const std::string m = failure_of(linux_config(dir + "/tec", dir + "/rate"));
  ::close(holder);
  fs::remove_all(dir);
  INFO(m);
  CHECK(m.find("is already in use by PID " + std::to_string(::getpid())) != std::string::npos);
  CHECK(m.find("gpiochip") == std::string::npos);  // the E/S line was not requested
}
