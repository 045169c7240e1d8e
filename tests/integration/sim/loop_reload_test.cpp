// A reload that changes the model-based loop (a new controller file from
// `gyrotc tune`, another setpoint's design) on the simulated board, lockstep:
// the new loop takes over from where the running one leaves the housing
// (control::ObserverLoop::adopt), so the current does not jump and the hold
// goes on.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc_catch.hpp"
#include "lockstep_board.hpp"

using namespace gyrotc;

namespace {

constexpr double kReloadS = 2400.0;  // the nominal plant holds 55 C long before

struct Period {
  double time_s;
  double current_a;
};

class ReloadRig {
 public:
  explicit ReloadRig(app::ControllerConfig start)
      : config_(std::move(start)),
        board_(test::plant_at(plant_, 16.0), 1, test::lockstep_board_options(plant_)),
        compensator_(fit::BiasModel::paper_reference()),
        controller_(config_, compensator_),
        profile_({{"hold", 0.0, 1e6, 16.0, 16.0}}),
        runner_(board_, controller_, profile_) {
    runner_.on_pid_tick([this](double now_s, const app::TecCommand& c) {
      periods_.push_back({now_s, c.enable ? c.current_a : 0.0});
    });
    runner_.on_record([this](const app::RecordRow& row) { rows_.push_back(row); });
  }

  void run_until(double t_s) { runner_.run_until(t_s); }
  app::Controller& controller() { return controller_; }

  // The largest change of the current from one period to the next in [from_s, to_s).
  double largest_step_a(double from_s, double to_s) const {
    double worst = 0.0;
    for (std::size_t k = 1; k < periods_.size(); ++k) {
      if (periods_[k].time_s >= from_s && periods_[k].time_s < to_s) {
        worst = std::max(worst, std::fabs(periods_[k].current_a - periods_[k - 1].current_a));
      }
    }
    return worst;
  }
  // The true casing's largest distance from setpoint_c in [from_s, to_s).
  double worst_error_c(double setpoint_c, double from_s, double to_s) const {
    double worst = 0.0;
    for (const auto& row : rows_) {
      if (row.time_s >= from_s && row.time_s < to_s) worst = std::max(worst, std::fabs(row.casing_c - setpoint_c));
    }
    return worst;
  }

 private:
  model::PlantParams plant_;
  app::ControllerConfig config_;
  hal::SimBoard board_;
  fit::Compensator compensator_;
  app::Controller controller_;
  model::ChamberProfile profile_;
  app::LockstepRunner runner_;
  std::vector<Period> periods_;
  std::vector<app::RecordRow> rows_;
};

// The reference loop's configuration with its model 30 % off in two of the
// housing's conductances (what a unit's own record may well give), designed
// afresh: another filter and another feedback.
app::ControllerConfig with_other_model(app::ControllerConfig c) {
  control::HousingModel m = c.observer->model;
  m.network.links.front().w_per_k *= 1.3;
  m.conductance_w_per_k *= 0.7;
  c.observer = std::make_shared<const control::ObserverLoopDesign>(control::design_observer_loop(m, c.observer->spec));
  return c;
}

}  // namespace

TEST_CASE("reload: a new model for the model-based loop takes over the hold without a step in the current") {
  const model::PlantParams plant;
  const app::ControllerConfig reference = app::controller_preset(app::ControllerMode::oracle, plant);
  ReloadRig rig(reference);
  rig.run_until(kReloadS);
  const double jitter_a = rig.largest_step_a(kReloadS - 600.0, kReloadS);
  app::ControllerReload next(with_other_model(reference));
  rig.controller().request_reload(next);
  rig.run_until(kReloadS + 1200.0);
  REQUIRE(rig.controller().reload_applied() == &next);
  const double step_a = rig.largest_step_a(kReloadS, kReloadS + 10.0);
  INFO("largest period-to-period step: " << jitter_a << " A in the hold before, " << step_a << " A at the reload");
  CHECK(step_a <= std::max(2.0 * jitter_a, 0.01));
  CHECK(rig.worst_error_c(55.0, kReloadS, kReloadS + 1200.0) < 0.0625);
}

TEST_CASE("reload: from the model-based loop to the PID and back, the current goes on from where it was") {
  const model::PlantParams plant;
  const app::ControllerConfig reference = app::controller_preset(app::ControllerMode::oracle, plant);
  ReloadRig rig(reference);
  rig.run_until(kReloadS);
  const double jitter_a = rig.largest_step_a(kReloadS - 600.0, kReloadS);
  app::ControllerConfig pid = app::controller_preset(app::ControllerMode::tuned, plant);
  app::ControllerReload to_pid(pid);
  rig.controller().request_reload(to_pid);
  rig.run_until(kReloadS + 600.0);
  app::ControllerReload back(reference);
  rig.controller().request_reload(back);
  rig.run_until(kReloadS + 1200.0);
  REQUIRE(rig.controller().reload_applied() == &back);
  const double to_pid_a = rig.largest_step_a(kReloadS, kReloadS + 10.0);
  const double back_a = rig.largest_step_a(kReloadS + 600.0, kReloadS + 610.0);
  INFO("hold before: " << jitter_a << " A; to the PID: " << to_pid_a << " A; back: " << back_a << " A");
  CHECK(to_pid_a <= std::max(2.0 * jitter_a, 0.02));
  CHECK(back_a <= std::max(2.0 * jitter_a, 0.02));
  CHECK(rig.worst_error_c(55.0, kReloadS, kReloadS + 1200.0) < 0.1);
}

TEST_CASE("reload: of two reloads in one period, the one asked for last runs, with its own loop") {
  const model::PlantParams plant;
  const app::ControllerConfig reference = app::controller_preset(app::ControllerMode::oracle, plant);
  ReloadRig rig(reference);
  rig.run_until(kReloadS);
  // The second is the first's model again (the session built each its own):
  // the loop it carries takes over, though it changes nothing against the first.
  app::ControllerReload first(with_other_model(reference));
  app::ControllerReload second(with_other_model(reference));
  rig.controller().request_reload(first);
  rig.controller().request_reload(second);
  rig.run_until(kReloadS + 600.0);
  REQUIRE(rig.controller().reload_applied() == &second);
  CHECK(rig.controller().config().observer == second.config.observer);
  CHECK(rig.largest_step_a(kReloadS, kReloadS + 10.0) <= 0.01);
  CHECK(rig.worst_error_c(55.0, kReloadS, kReloadS + 600.0) < 0.0625);
}
