// The emulator's control socket: one line in, one line out.
#include "gyrotc/emu/control_socket.hpp"

#include <string>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

TEST_CASE("control socket: a command reaches the handler and its answer comes back") {
  const std::string path = test::scratch_dir() + "/control.sock";
  std::string seen;
  emu::ControlServer server(path, [&seen](const std::string& command) {
    seen = command;
    return std::string("ok done");
  });
  CHECK(emu::control_request(path, "fault casing crc") == "ok done");
  CHECK(seen == "fault casing crc");
}

TEST_CASE("control socket: a handler that throws answers with the error") {
  const std::string path = test::scratch_dir() + "/control-throws.sock";
  emu::ControlServer server(path, [](const std::string&) -> std::string { throw std::runtime_error("bad"); });
  CHECK(emu::control_request(path, "status") == "error: bad");
}

TEST_CASE("control socket: with no emulator listening the request says so") {
  try {
    (void)emu::control_request(test::scratch_dir() + "/nobody.sock", "status");
    FAIL("no error");
  } catch (const app::RuntimeFailure& e) {
    CHECK_THAT(e.what(), Catch::Contains("no gyrotc-emu listens"));
  }
}
