#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gyrotc/hal/board.hpp"
#include "gyrotc/hal/chips/ad5060.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/chips/ds18b20.hpp"
#include "gyrotc/hal/chips/opa548.hpp"
#include "gyrotc/hal/chips/tec_stage.hpp"
#include "gyrotc/hal/linux/gpiod_line.hpp"
#include "gyrotc/hal/linux/monotonic_clock.hpp"
#include "gyrotc/hal/linux/spidev_bus.hpp"
#include "gyrotc/hal/linux/w1_sysfs.hpp"

namespace gyrotc::hal {

// A GPIO line as configured: "chip:line", chip by name/path/label/number,
// line by name or offset.
struct GpioRef {
  std::string chip;
  std::string line;
  GpioBias bias = GpioBias::as_is;  // the pin's pull (an opto sense usually needs pull_up)
  bool active_low = false;          // levels and edges inverted on the pin
};

struct W1SensorConfig {
  std::string w1_root = W1Sysfs::kDefaultRoot;
  std::string id;  // empty: the first 28-* device
  Ds18b20Options options;
};

struct LinuxBoardConfig {
  std::string adc_spi = "/dev/spidev0.0";
  GpioRef adc_drdy{"gpiochip0", "25"};
  Ads1251Config adc;
  std::string rate_dac_spi = "/dev/spidev6.0";  // mode 1: not SPI1 on a Pi (docs/BOARD-rpi4.md)
  Ad5060Config rate_dac;
  std::string tec_dac_spi = "/dev/spidev6.1";
  Ad5060Config tec_dac{.vref_v = 5.0};  // VDD = 5 V, as the plant model's TEC stage
  GpioRef opa548_es{"gpiochip0", "24"};  // push-pull drive of E/S, high = enabled
  std::optional<GpioRef> opa548_es_sense;  // a second line reading E/S, if wired
  TecStageConfig tec;
  W1SensorConfig casing_sensor;
  std::optional<W1SensorConfig> ambient_sensor;
};

// A device of the board that could not be opened, and why.
struct DeviceFailure {
  std::string device;  // "adc", "rate_dac", "tec_dac", "opa548", "casing_sensor", "ambient_sensor"
  std::string message;
};

// What safe_off() did: the TEC path (TEC DAC to 0 A, OPA548 disabled) and,
// as a courtesy, the rate DAC at mid-scale.
struct SafeOffReport {
  Status tec_dac;
  Status opa548;
  Status rate_dac;
  bool tec_safe() const noexcept { return tec_dac.ok() && opa548.ok(); }
};

// The real board: spidev, libgpiod, w1 sysfs, CLOCK_MONOTONIC. Opening locks
// every spidev first (a board another gyrotc holds fails with
// ErrorCode::busy and is not written at all), then puts the outputs in
// their safe state (TEC DAC at 0 A, OPA548 disabled, rate DAC at mid-scale);
// the destructor calls tec.safe_off().
class LinuxBoard {
 public:
  struct Opened {
    std::unique_ptr<LinuxBoard> board;    // null if any device failed
    std::vector<DeviceFailure> failures;  // one entry per failed device
  };
  // Tries every device (so all problems are reported at once).
  static Opened open(const LinuxBoardConfig& config);
  // Opens only the TEC DAC, the OPA548's E/S line and the rate DAC (so a
  // missing sensor or ADC does not stand in the way) and makes them safe.
  static SafeOffReport safe_off(const LinuxBoardConfig& config);

  ~LinuxBoard();
  LinuxBoard(const LinuxBoard&) = delete;
  LinuxBoard& operator=(const LinuxBoard&) = delete;

  Board board() noexcept;

 private:
  LinuxBoard() = default;

  MonotonicClock clock_;
  std::unique_ptr<SpidevBus> adc_spi_, rate_dac_spi_, tec_dac_spi_;
  std::unique_ptr<GpiodLine> drdy_, es_drive_, es_sense_;
  std::unique_ptr<Ads1251> adc_;
  std::unique_ptr<Ad5060> rate_dac_, tec_dac_;
  std::unique_ptr<Opa548> opa548_;
  std::unique_ptr<TecStage> tec_;
  std::unique_ptr<W1Sysfs> casing_w1_, ambient_w1_;
  std::unique_ptr<Ds18b20> casing_, ambient_;
};

}  // namespace gyrotc::hal
