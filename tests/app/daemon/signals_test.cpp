#include <signal.h>
#include <unistd.h>

#include "gyrotc/app/daemon/signals.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::DaemonSignals;

TEST_CASE("SIGTERM and SIGINT are taken as stop, SIGHUP as reload") {
  DaemonSignals signals;
  ::kill(::getpid(), SIGHUP);
  CHECK(signals.wait(1.0) == DaemonSignals::Event::reload);
  ::kill(::getpid(), SIGTERM);
  CHECK(signals.wait(1.0) == DaemonSignals::Event::stop);
  CHECK(signals.last_signal() == SIGTERM);
  ::kill(::getpid(), SIGINT);
  CHECK(signals.wait(1.0) == DaemonSignals::Event::stop);
  CHECK(signals.last_signal() == SIGINT);
}

TEST_CASE("waiting for a signal returns none when the time runs out") {
  DaemonSignals signals;
  CHECK(signals.wait(0.01) == DaemonSignals::Event::none);
}
