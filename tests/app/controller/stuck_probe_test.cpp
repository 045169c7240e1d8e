// The active stuck-sensor probe (runtime/stuck_probe.hpp): when it moves the
// model-based loop's target, how far, and when it calls a reading stuck.
#include "gyrotc/app/runtime/stuck_probe.hpp"

#include "gyrotc_catch.hpp"

using namespace gyrotc::app;

namespace {

constexpr double kStepC = StuckProbe::kStepC;
constexpr double kPastEdgeC = (0.5 + StuckProbe::kMarginSteps) * kStepC;

FailSafeLimits probing_after(double probe_s) {
  FailSafeLimits l;
  l.stuck_probe_s = probe_s;
  l.stuck_probe_hold_s = 60.0;
  return l;
}

}  // namespace

TEST_CASE("stuck probe: off by default, the target never moves") {
  const FailSafeLimits l;
  StuckProbe probe(l);
  for (double t = 0.0; t < 5000.0; t += 2.0) CHECK(probe.on_period(t, 55.0, t, 55.0) == 0.0);
  CHECK_FALSE(probe.take_failed());
}

TEST_CASE("stuck probe: a reading on one step for stuck_probe_s moves the target past the step's upper edge") {
  const FailSafeLimits l = probing_after(300.0);
  StuckProbe probe(l);
  CHECK(probe.on_period(298.0, 55.0, 298.0, 55.0) == 0.0);
  CHECK(probe.on_period(300.0, 55.0, 300.0, 55.0) == Approx(kPastEdgeC));
  CHECK(probe.probing());
}

TEST_CASE("stuck probe: a reading that follows ends the probe, the target back, no fault") {
  const FailSafeLimits l = probing_after(300.0);
  StuckProbe probe(l);
  probe.on_period(300.0, 55.0, 300.0, 55.0);
  probe.on_period(320.0, 55.0, 320.0, 55.0);
  // The reading changed 10 s ago: after the probe began.
  CHECK(probe.on_period(340.0, 55.0625, 10.0, 55.0) == 0.0);
  CHECK_FALSE(probe.probing());
  CHECK_FALSE(probe.take_failed());
}

TEST_CASE("stuck probe: a reading that follows neither edge is stuck after both holds") {
  const FailSafeLimits l = probing_after(300.0);
  StuckProbe probe(l);
  double t = 300.0;
  probe.on_period(t, 55.0, t, 55.0);
  for (t += 2.0; t < 360.0; t += 2.0) CHECK(probe.on_period(t, 55.0, t, 55.0) == Approx(kPastEdgeC));
  CHECK(probe.on_period(t, 55.0, t, 55.0) == Approx(-kPastEdgeC));  // 60 s up: now the lower edge
  CHECK_FALSE(probe.take_failed());
  for (t += 2.0; t < 420.0; t += 2.0) probe.on_period(t, 55.0, t, 55.0);
  CHECK(probe.on_period(t, 55.0, t, 55.0) == 0.0);
  CHECK(probe.take_failed());
  CHECK_FALSE(probe.take_failed());  // reported once
}

TEST_CASE("stuck probe: a period the loop did not drive cancels the probe") {
  const FailSafeLimits l = probing_after(300.0);
  StuckProbe probe(l);
  probe.on_period(300.0, 55.0, 300.0, 55.0);
  probe.cancel();
  CHECK_FALSE(probe.probing());
  CHECK(probe.offset_c() == 0.0);
  CHECK_FALSE(probe.take_failed());
}
