#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "gyrotc/hal/linux/linux_board.hpp"

// The board's GPIO lines (ADS1251 DRDY/DOUT, OPA548 E/S drive and sense) as
// lines of a gpio-sim device (the kernel's GPIO simulator, configured through
// configfs: Documentation/admin-guide/gpio/gpio-sim.rst). The kernel numbers
// gpio-sim chips itself, so the configuration must name each chip by label
// ("gyrotc-emu:DRDY"): the emulator gives a bank that label, and the line its
// name (or takes its offset), so that the daemon's own lookup finds it.
namespace gyrotc::emu {

struct GpioSimLine {
  std::string key;          // "devices.adc.drdy", for messages
  std::string name;         // the line's name ("" when the configuration gives an offset)
  unsigned offset = 0;
};

struct GpioSimBank {
  std::string label;
  unsigned num_lines = 0;
  std::vector<GpioSimLine> lines;
};

// Where one configured line ended up.
struct GpioSimPlace {
  std::size_t bank = 0;
  unsigned offset = 0;
  bool active_low = false;  // the wiring inverts the level (the configuration's <key>_active_low)
};

struct GpioSimPlan {
  std::vector<GpioSimBank> banks;
  GpioSimPlace drdy;
  GpioSimPlace es;
  std::optional<GpioSimPlace> es_sense;
};

// Throws app::InputError naming the key when a chip is not a label (a path,
// a number or "gpiochipN") or two keys name the same line.
GpioSimPlan plan_gpio_sim(const hal::LinuxBoardConfig& devices);

// A live gpio-sim device made from a plan: <configfs_root>/<name> with one
// bank per label, its lines named; live on construction, removed on
// destruction. Throws app::RuntimeFailure naming the file and, when the
// gpio-sim folder is missing, the module to load.
class GpioSimDevice {
 public:
  GpioSimDevice(const GpioSimPlan& plan, std::string name, std::string configfs_root = "/sys/kernel/config/gpio-sim",
                std::string sysfs_root = "/sys/devices/platform");
  ~GpioSimDevice();
  GpioSimDevice(const GpioSimDevice&) = delete;
  GpioSimDevice& operator=(const GpioSimDevice&) = delete;

  // "gpiochipN" of a bank, and the sysfs folder of one of its lines.
  const std::string& chip_name(std::size_t bank) const { return chips_.at(bank); }
  std::string line_dir(std::size_t bank, unsigned offset) const;

 private:
  void remove() noexcept;

  GpioSimPlan plan_;
  std::string dir_;
  std::string sysfs_root_;
  std::string dev_name_;
  std::vector<std::string> chips_;
  bool live_ = false;
};

}  // namespace gyrotc::emu
