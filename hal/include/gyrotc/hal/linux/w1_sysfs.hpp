#pragma once

#include <string>

#include "gyrotc/hal/w1_device.hpp"

namespace gyrotc::hal {

// A DS18B20 under the w1 sysfs tree: <root>/<id>/w1_slave and temperature.
// With an empty id the first "28-*" directory (DS18B20 family code 0x28) is
// used, looked up again at every read while none is found, so a sensor that
// appears later is picked up.
class W1Sysfs final : public W1Device {
 public:
  static constexpr const char* kDefaultRoot = "/sys/bus/w1/devices";

  explicit W1Sysfs(std::string root = kDefaultRoot, std::string id = {});

  // The device directory in use, or "<root>/28-*" while none is found.
  const std::string& device_path() const noexcept { return device_path_; }

 private:
  Result<std::size_t> do_read(W1File file, std::span<char> buffer) override;
  std::string_view do_name() const noexcept override { return device_path_; }
  bool find_device();

  std::string root_;
  std::string id_;
  std::string device_path_;
};

}  // namespace gyrotc::hal
