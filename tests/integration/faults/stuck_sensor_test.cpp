// A casing sensor that freezes on the simulated board (issue 75, item 3):
// the model-based loop's shadow filter sees the frozen reading left behind
// by the housing and raises temp_stuck; a healthy reading that sits on one
// step while the room moves is no such thing.
#include <algorithm>
#include <cmath>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

constexpr double kSettledS = 2400.0;  // the nominal plant holds 55 C long before

// The room at 16 C while the loop settles, then warming by `warming_c` over
// 100 s (the virtual board's case: 8 C), then held.
model::ChamberProfile warming_room(double warming_c) {
  return model::ChamberProfile({{"settle", 0.0, kSettledS, 16.0, 16.0},
                                {"warming", kSettledS, kSettledS + 100.0, 16.0, 16.0 + warming_c},
                                {"warm", kSettledS + 100.0, kSettledS + 1500.0, 16.0 + warming_c, 16.0 + warming_c}});
}

struct StuckRun {
  std::vector<app::RecordRow> rows;
  double detected_s = std::nan("");  // the first row with temp_stuck
};

// The nominal plant under `mode`, with an ambient sensor, the casing sensor
// frozen at freeze_s (never when negative).
StuckRun run(app::ControllerMode mode, double warming_c, double freeze_s, double probe_s = 0.0) {
  static const fit::BiasModel calibration = fit::BiasModel::paper_reference();
  app::SimulationSetup s;
  s.controller = app::controller_preset(mode, s.plant);
  s.controller.limits.stuck_probe_s = probe_s;
  s.calibration = &calibration;
  s.sample_rate_hz = 20.0;
  s.ambient_sensor = true;
  if (freeze_s >= 0.0) s.on_record = app::freeze_casing_sensor_at(freeze_s);
  StuckRun r;
  r.rows = app::run_simulation(s, warming_room(warming_c)).rows;
  for (const auto& row : r.rows) {
    if ((row.flags & app::kFlagTempStuck) != 0) {
      r.detected_s = row.time_s;
      break;
    }
  }
  return r;
}

const app::RecordRow& row_at(const StuckRun& r, double t_s) {
  for (const auto& row : r.rows) {
    if (row.time_s >= t_s) return row;
  }
  return r.rows.back();
}

}  // namespace

// Frozen in the warm-up: the loop heats at its limit, its model says the
// housing rises, the reading stays. On the nominal plant the shadow leaves
// the frozen reading by two steps and four of its sigma in 4-5 s, and
// stuck_sigma_s (10 s) later the fault is named: 14-15 s after the freeze
// at 200, 400 and 600 s, the true casing then 0.7-0.9 C above the frozen
// reading (the drive criterion alone takes stuck_s, 300 s).
TEST_CASE("stuck sensor: the model-based loop names a reading frozen in the warm-up within 30 s") {
  constexpr double kFreezeS = 400.0;
  const StuckRun r = run(app::ControllerMode::oracle, 0.0, kFreezeS);
  REQUIRE(std::isfinite(r.detected_s));
  const double frozen_c = row_at(r, kFreezeS + 1.0).sensor_c;
  CHECK(r.detected_s > kFreezeS);
  CHECK(r.detected_s <= kFreezeS + 30.0);
  CHECK(std::fabs(row_at(r, r.detected_s).casing_c - frozen_c) < 1.5);
  // The TEC off from the next period on.
  CHECK((row_at(r, r.detected_s + 2.0).flags & app::kFlagTecOff) != 0);
}

TEST_CASE("stuck sensor: a healthy reading that sits on one step while the room warms 8 C is no fault") {
  const StuckRun r = run(app::ControllerMode::oracle, 8.0, -1.0);
  CHECK(std::isnan(r.detected_s));
  CHECK(row_at(r, kSettledS + 600.0).sensor_c == row_at(r, kSettledS - 100.0).sensor_c);  // the case it is
}

// Frozen in the hold: the loop holds on its model (the ambient reading and
// the currents), and the check, sharing that model, has nothing to see; on
// the plant its model is, the housing stays held.
TEST_CASE("stuck sensor: frozen in the hold, the model-based loop holds the housing on its model") {
  const StuckRun r = run(app::ControllerMode::oracle, 8.0, kSettledS - 100.0);
  double worst_c = 0.0;
  for (const auto& row : r.rows) {
    if (row.time_s >= kSettledS - 100.0) worst_c = std::max(worst_c, std::fabs(row.casing_c - 55.0));
  }
  CHECK(worst_c < 0.1);
}

// The active probe (failsafe.stuck_probe_s): after that long on one step the
// loop's target goes past the step's upper edge, then its lower one, for
// stuck_probe_hold_s (60 s) each; a frozen reading follows neither.
TEST_CASE("stuck sensor: the probe names a reading frozen in the hold that the model cannot see") {
  constexpr double kProbeS = 600.0;
  const StuckRun r = run(app::ControllerMode::oracle, 8.0, kSettledS - 100.0, kProbeS);
  REQUIRE(std::isfinite(r.detected_s));
  CHECK(r.detected_s > kSettledS - 100.0);
  CHECK(r.detected_s <= kSettledS - 100.0 + kProbeS + 2.0 * 60.0 + 30.0);
}

TEST_CASE("stuck sensor: a healthy reading follows the probe, no fault, the hold within a step") {
  constexpr double kProbeS = 600.0;
  const StuckRun r = run(app::ControllerMode::oracle, 8.0, -1.0, kProbeS);
  CHECK(std::isnan(r.detected_s));
  double worst_c = 0.0;
  for (const auto& row : r.rows) {
    if (row.time_s >= kSettledS - 600.0) worst_c = std::max(worst_c, std::fabs(row.casing_c - 55.0));
  }
  CHECK(worst_c < 0.0625);
}
