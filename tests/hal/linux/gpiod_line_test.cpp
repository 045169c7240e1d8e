#include "gyrotc/hal/linux/gpiod_line.hpp"

#include <string>

#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

TEST_CASE("a missing gpiochip name is an error naming it and the errno text") {
  const auto line = GpiodLine::open({.chip = "gpiochip-gyrotc-missing", .line = "17", .mode = GpioMode::input});
  REQUIRE_FALSE(line.ok());
  CHECK(line.error().code() == ErrorCode::not_found);
  CHECK(std::string(line.error().message()) ==
        "cannot open gpiochip 'gpiochip-gyrotc-missing': No such file or directory");
}

TEST_CASE("a missing gpiochip path is an error naming the path") {
  const auto line = GpiodLine::open({.chip = "/dev/gpiochip-gyrotc-missing", .line = "DRDY",
                                     .mode = GpioMode::edge_events});
  REQUIRE_FALSE(line.ok());
  CHECK(std::string(line.error().message()) ==
        "cannot open gpiochip '/dev/gpiochip-gyrotc-missing': No such file or directory");
}

TEST_CASE("a path that is not a gpiochip is refused, naming it") {
  const auto line = GpiodLine::open({.chip = "/dev/null", .line = "0", .mode = GpioMode::output});
  REQUIRE_FALSE(line.ok());
  CHECK(std::string(line.error().message()).find("cannot open gpiochip '/dev/null': ") == 0);
}
