#include "gyrotc/hal/linux/gpio_persistence.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

TEST_CASE("the pinctrl-bcm2835 persist_gpio_outputs parameter is read as Y, N or absent") {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("gyrotc-persist-" + std::to_string(::getpid()))).string();
  std::ofstream(path) << "Y\n";
  CHECK(gpio_outputs_persist(path.c_str()) == true);
  std::ofstream(path) << "N\n";
  CHECK(gpio_outputs_persist(path.c_str()) == false);
  std::filesystem::remove(path);
  CHECK_FALSE(gpio_outputs_persist(path.c_str()).has_value());
}
