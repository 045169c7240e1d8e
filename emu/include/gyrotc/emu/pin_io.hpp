#pragma once

#include <optional>
#include <string>

// A GPIO line as the emulated board's side of the wire sees it: an input of
// the SBC the emulator drives (DRDY/DOUT, E/S sense), or an output of the SBC
// it reads (E/S drive). Levels are physical (the configuration's active_low
// is the SBC's business, applied by whoever wires the emulator).
namespace gyrotc::emu {

class PinOutput {
 public:
  virtual ~PinOutput() = default;
  virtual void set_level(bool high) noexcept = 0;
};

class PinInput {
 public:
  virtual ~PinInput() = default;
  // The level the SBC drives, or nothing while it cannot be read.
  virtual std::optional<bool> level() noexcept = 0;
};

// gpio-sim's per-line attributes (/sys/devices/platform/<dev>/<chip>/sim_gpio<N>):
// `pull` ("pull-up" / "pull-down") sets the level an input line reads and
// makes its edges; `value` reads what a consumer drives on an output line.
// Both files are opened once; throw app::RuntimeFailure naming the file.
class SysfsPullPin final : public PinOutput {
 public:
  explicit SysfsPullPin(const std::string& line_dir);
  ~SysfsPullPin() override;
  SysfsPullPin(const SysfsPullPin&) = delete;
  SysfsPullPin& operator=(const SysfsPullPin&) = delete;
  void set_level(bool high) noexcept override;
  int errors() const noexcept { return errors_; }

 private:
  std::string path_;
  int fd_ = -1;
  int errors_ = 0;
};

class SysfsValuePin final : public PinInput {
 public:
  explicit SysfsValuePin(const std::string& line_dir);
  ~SysfsValuePin() override;
  SysfsValuePin(const SysfsValuePin&) = delete;
  SysfsValuePin& operator=(const SysfsValuePin&) = delete;
  std::optional<bool> level() noexcept override;

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace gyrotc::emu
