// GpiodLine, the libgpiod back-end of GpioLine, against a fake chip behind
// the libgpiod calls (fake_gpiochip.hpp): the same specification for the
// 1.6 and the 2.x API, whichever this build uses.
#include <cerrno>
#include "gyrotc/hal/linux/gpiod_line.hpp"

#include <cstdint>
#include <memory>
#include <string>

#include "fake_gpiochip.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

namespace {

constexpr unsigned kDrdy = 25;
constexpr unsigned kEs = 24;

// The fake chip, armed for the test's lifetime.
struct Rig {
  FakeGpiochip chip;
  Rig() { FakeGpiochip::armed() = &chip; }
  ~Rig() { FakeGpiochip::armed() = nullptr; }
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  std::unique_ptr<GpiodLine> open(GpiodLineSpec spec) {
    auto line = GpiodLine::open(spec);
    if (!line) FAIL(std::string(line.error().message()));
    return std::move(line.value());
  }
  std::unique_ptr<GpiodLine> drdy() {
    return open({.chip = chip.name, .line = std::to_string(kDrdy), .mode = GpioMode::edge_events});
  }
  std::unique_ptr<GpiodLine> es() {
    return open({.chip = chip.name, .line = std::to_string(kEs), .mode = GpioMode::output});
  }
};

double seconds(std::uint64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace

TEST_CASE("an output line is requested for the consumer gyrotc, push-pull, at its initial level") {
  Rig rig;
  rig.chip.lines[kEs].level = 1;  // whatever the pin did before
  const auto es = rig.es();
  const FakeLine& l = rig.chip.lines[kEs];
  CHECK(l.requested);
  CHECK(l.consumer == "gyrotc");
  CHECK(l.direction == FakeDirection::output);
  CHECK_FALSE(l.open_drain);
  CHECK(l.level == 0);  // initial_high = false: the OPA548 E/S disabled from the request on
}

TEST_CASE("set drives an output line and get reads it back") {
  Rig rig;
  const auto es = rig.es();
  REQUIRE(es->set(true).ok());
  CHECK(rig.chip.lines[kEs].level == 1);
  CHECK(es->get().value());
  REQUIRE(es->set(false).ok());
  CHECK(rig.chip.lines[kEs].level == 0);
  CHECK_FALSE(es->get().value());
}

TEST_CASE("closing a line releases it and its chip") {
  Rig rig;
  {
    const auto es = rig.es();
    CHECK(rig.chip.open_handles == 1);
  }
  CHECK_FALSE(rig.chip.lines[kEs].requested);
  CHECK(rig.chip.open_handles == 0);
  const auto again = rig.es();  // free again
  CHECK(rig.chip.lines[kEs].requested);
}

TEST_CASE("an edge line asks the kernel for falling edges only, stamped on CLOCK_MONOTONIC") {
  Rig rig;
  const auto drdy = rig.drdy();
  const FakeLine& l = rig.chip.lines[kDrdy];
  CHECK(l.direction == FakeDirection::input);
  CHECK(l.edges == FakeEdges::falling);
  CHECK(l.clock == FakeClock::monotonic);
}

TEST_CASE("a falling edge wakes the wait with the kernel's time stamp") {
  Rig rig;
  const auto drdy = rig.drdy();
  rig.chip.drive(kDrdy, 1, monotonic_now_ns());
  const std::uint64_t fall_ns = monotonic_now_ns() - 250'000;
  rig.chip.drive(kDrdy, 0, fall_ns);
  const auto edge = drdy->wait_edge(Edge::falling, 0.002);
  REQUIRE(edge.ok());
  CHECK(*edge == Approx(seconds(fall_ns)).margin(1e-9));
  CHECK(rig.chip.lines[kDrdy].last_wait_timeout_ns == 2'000'000);
}

TEST_CASE("without a falling edge the wait times out after the time asked for") {
  Rig rig;
  const auto drdy = rig.drdy();
  rig.chip.drive(kDrdy, 1, monotonic_now_ns());  // a rising edge is not queued
  const auto edge = drdy->wait_edge(Edge::falling, 0.25);
  REQUIRE_FALSE(edge.ok());
  CHECK(edge.error().code() == ErrorCode::timeout);
  CHECK(rig.chip.lines[kDrdy].last_wait_timeout_ns == 250'000'000);
  CHECK(std::string(edge.error().message()) == "no falling edge on GPIO 'gpiochip7:25' within 0.250 s");
}

TEST_CASE("edges queue in order and discard_edges drops the ones left") {
  Rig rig;
  const auto drdy = rig.drdy();
  const std::uint64_t t0 = monotonic_now_ns() - 3'000'000;
  for (std::uint64_t k = 0; k < 3; ++k) {
    rig.chip.drive(kDrdy, 1, t0 + k * 1'000'000);
    rig.chip.drive(kDrdy, 0, t0 + k * 1'000'000 + 15'000);
  }
  const auto first = drdy->wait_edge(Edge::falling, 0.001);
  REQUIRE(first.ok());
  CHECK(*first == Approx(seconds(t0 + 15'000)).margin(1e-9));
  const auto dropped = drdy->discard_edges();
  REQUIRE(dropped.ok());
  CHECK(*dropped == 2);
  CHECK(drdy->wait_edge(Edge::falling, 0.001).error().code() == ErrorCode::timeout);
  CHECK(drdy->discard_edges().value() == 0);
}

TEST_CASE("waiting for the edge that was not requested is refused") {
  Rig rig;
  const auto drdy = rig.drdy();
  const auto edge = drdy->wait_edge(Edge::rising, 0.001);
  REQUIRE_FALSE(edge.ok());
  CHECK(edge.error().code() == ErrorCode::invalid_config);
}

TEST_CASE("bias and active-low reach the request, and levels read logically") {
  Rig rig;
  const auto sense = rig.open({.chip = rig.chip.name, .line = "OPA548_ES_SENSE", .mode = GpioMode::input,
                               .bias = GpioBias::pull_up, .active_low = true});
  const FakeLine& l = rig.chip.lines[23];
  CHECK(l.bias == FakeBias::pull_up);
  CHECK(l.active_low);
  rig.chip.lines[23].level = 0;
  CHECK(sense->get().value());
  rig.chip.lines[23].level = 1;
  CHECK_FALSE(sense->get().value());
}

TEST_CASE("an active-low output starts inactive, i.e. high on the pin") {
  Rig rig;
  const auto es = rig.open({.chip = rig.chip.name, .line = "24", .mode = GpioMode::output, .active_low = true});
  CHECK(rig.chip.lines[kEs].level == 1);
  REQUIRE(es->set(true).ok());
  CHECK(rig.chip.lines[kEs].level == 0);
}

TEST_CASE("a line is found by its name") {
  Rig rig;
  const auto drdy = rig.open({.chip = rig.chip.name, .line = "DRDY", .mode = GpioMode::edge_events});
  CHECK(rig.chip.lines[kDrdy].requested);
  CHECK(drdy->name() == "gpiochip7:DRDY");
}

TEST_CASE("a chip is found by its name, path, number or label") {
  Rig rig;
  for (const std::string chip : {"gpiochip7", "/dev/gpiochip7", "7", "fake-pinctrl"}) {
    INFO(chip);
    const auto es = GpiodLine::open({.chip = chip, .line = "24", .mode = GpioMode::output});
    REQUIRE(es.ok());
    CHECK(rig.chip.lines[kEs].requested);
  }
}

TEST_CASE("a chip looked up by label that the process may not open is reported as such, not as missing") {
  Rig rig;
  rig.chip.open_errno = EACCES;  // a node udev has not given the group yet
  const auto line = GpiodLine::open({.chip = "fake-pinctrl", .line = "24", .mode = GpioMode::output});
  REQUIRE_FALSE(line.ok());
  CHECK(std::string(line.error().message()) == "cannot open gpiochip 'fake-pinctrl': Permission denied");
}

TEST_CASE("a line another consumer holds is refused with the errno text") {
  Rig rig;
  rig.chip.lines[kEs].requested = true;
  rig.chip.lines[kEs].consumer = "other";
  const auto es = GpiodLine::open({.chip = "gpiochip7", .line = "24", .mode = GpioMode::output});
  REQUIRE_FALSE(es.ok());
  CHECK(std::string(es.error().message()) ==
        "cannot request GPIO line 'gpiochip7:24': Device or resource busy");
  CHECK(rig.chip.open_handles == 0);  // the chip was closed again
}

TEST_CASE("an unknown line name is an error naming chip and line") {
  Rig rig;
  const auto line = GpiodLine::open({.chip = "gpiochip7", .line = "NOPE", .mode = GpioMode::input});
  REQUIRE_FALSE(line.ok());
  CHECK(std::string(line.error().message()) == "no GPIO line 'gpiochip7:NOPE': No such file or directory");
}

TEST_CASE("set on a line that is not an output is refused") {
  Rig rig;
  const auto drdy = rig.drdy();
  CHECK(drdy->set(true).error().code() == ErrorCode::invalid_config);
}

TEST_CASE("the library version is the one linked") {
  std::string major = "libgpiod ";  // built step by step: GCC 12's -Wrestrict misfires on a + chain here
  major += std::to_string(GYROTC_GPIOD_API);
  major += '.';
  CHECK(GpiodLine::library_version().rfind(major, 0) == 0);
}

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
