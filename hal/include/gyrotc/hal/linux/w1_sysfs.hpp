#pragma once

#include <string>
#include <vector>

#include "gyrotc/hal/w1_device.hpp"

namespace gyrotc::hal {

// A DS18B20 under the w1 sysfs tree: <root>/<id>/{w1_slave,temperature,
// resolution}. With an empty id the only "28-*" directory (DS18B20 family
// code 0x28) is used, looked up again at every read while there is none; with
// several and no id there is no telling which is which, and every read fails
// (ErrorCode::invalid_config) naming them.
class W1Sysfs final : public W1Device {
 public:
  static constexpr const char* kDefaultRoot = "/sys/bus/w1/devices";

  explicit W1Sysfs(std::string root = kDefaultRoot, std::string id = {});

  // The DS18B20 ids (28-*) under root, sorted; an error if root cannot be read.
  static Result<std::vector<std::string>> list_ds18b20(const std::string& root);
  // The device directory in use, or "<root>/28-*" while none is bound.
  const std::string& device_path() const noexcept { return device_path_; }
  // Binds an empty id to the only DS18B20 under root; explains why not.
  Status find_device();

 private:
  Result<std::size_t> do_read(W1File file, std::span<char> buffer) override;
  std::string_view do_name() const noexcept override { return device_path_; }

  std::string root_;
  std::string id_;
  std::string device_path_;
};

}  // namespace gyrotc::hal
