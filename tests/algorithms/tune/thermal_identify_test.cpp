// Identification of the unit's thermal model from its own record
// (tune/thermal_identify.hpp), on records from two generators that are not
// the tune model: the plant simulator (model/plant.hpp) run through the
// identification experiment with the DS18B20's steps and timing, and a
// three-node casing with a lagging sensor, sensor noise and a drifting room,
// which the tune model cannot represent exactly.
#include <Eigen/Dense>

#include <algorithm>
#include <iterator>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/algorithms/tune/controller_design.hpp"
#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/algorithms/tune/identified_housing.hpp"
#include "gyrotc/algorithms/tune/thermal_identify.hpp"
#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"

using namespace gyrotc;
using tune::ThermalFit;
using tune::TuneRecord;

namespace {

// What a board records while the experiment runs on the plant simulator: the
// DS18B20 converts every second (the reading reflects the start of the
// conversion and arrives 0.75 s later), the experiment sets the command every
// 2 s from the latest reading, one row a second with the latest reading, the
// command and the ambient reading. The experiment commands up to
// commanded_limit_a (default: the stage's own limit).
TuneRecord plant_record(model::PlantParams p, double room_c, bool with_ambient = true, double commanded_limit_a = 0.0) {
  if (!(commanded_limit_a > 0.0)) commanded_limit_a = p.current_limit_a;
  p.initial_temp_c = room_c;
  model::Plant plant(p, 7);
  plant.set_ambient_c(room_c);
  plant.set_tec_enabled(true);
  tune::IdentificationExperiment experiment;
  TuneRecord r;
  // A network plant's DS18B20 reads through its own lag (Plant::sensor_c).
  auto sensed_c = [&] { return p.network ? plant.sensor_c() : plant.casing_c(); };
  double reading = test::ds18b20_steps_c(sensed_c());
  double command = 0.0;
  constexpr double kStepS = 0.25;
  double pending = reading;
  for (int q = 0;; ++q) {
    const double t = q * kStepS;
    if (q % 4 == 0) pending = test::ds18b20_steps_c(sensed_c());  // a conversion starts
    if (q % 4 == 3) reading = pending;                      // ... and arrives 0.75 s later
    if (q % 8 == 0 && q > 0) {
      control::TecProgramInput in{t, reading, with_ambient ? test::ds18b20_steps_c(room_c) : std::nan(""), 55.0,
                                  -commanded_limit_a, commanded_limit_a};
      const control::TecProgramOutput o = experiment.next(in);
      if (o.finished) break;
      command = o.current_a;
      plant.set_tec_drive_v(0.5 * p.dac_vref_v + command / p.gain_a_per_v);
    }
    if (q % 4 == 0 && q > 0) {
      r.time_s.push_back(t);
      r.sensor_c.push_back(reading);
      r.tec_a.push_back(command);
      if (with_ambient) r.ambient_c.push_back(test::ds18b20_steps_c(room_c));
    }
    plant.advance(kStepS);
  }
  return r;
}

// The tune model's rates of a plant (per unit of casing + die heat capacity).
double truth_peltier(const model::PlantParams& p) {
  return p.tec_seebeck_v_per_k / (p.casing_capacity_j_per_k + p.die_capacity_j_per_k);
}
double truth_joule(const model::PlantParams& p) {
  return p.tec_resistance_ohm / (2.0 * (p.casing_capacity_j_per_k + p.die_capacity_j_per_k));
}

const tune::Estimate& estimate(const ThermalFit& fit, const std::string& name) {
  for (const auto& e : fit.estimates) {
    if (e.name == name) return e;
  }
  throw std::runtime_error("no estimate " + name);
}

const ThermalFit& nominal_fit() {
  static const ThermalFit fit = tune::identify_thermal(plant_record(model::PlantParams{}, 16.0));
  return fit;
}

// A casing in two halves (TEC side, sensor side) with an internal
// conductance, a shell, the sensor lagging its half by 8 s, AR(1) sensor
// noise before the DS18B20's steps, and a room drifting +/- 1 C over 2 h.
struct ThreeNode {
  double c_tec = 160.0, c_sensor = 150.0, c_shell = 60.0;
  double g_halves = 2.0, g_tec = 0.1, g_shell = 0.55;
  double s = 0.05, r = 11.0, power = 0.25;
  double sensor_lag_s = 8.0;

  // d/dt (T_tec, T_sensor, T_shell) = A T + b at current i.
  void network(double i, double room_c, Eigen::Matrix3d& a, Eigen::Vector3d& b) const {
    a << (-g_halves - g_tec + s * i) / c_tec, g_halves / c_tec, g_tec / c_tec,  //
        g_halves / c_sensor, -g_halves / c_sensor, 0.0,                          //
        g_tec / c_shell, 0.0, (-g_tec - g_shell - s * i) / c_shell;
    b << (s * i * 273.15 + 0.5 * i * i * r) / c_tec, power / c_sensor,
        (-s * i * 273.15 + 0.5 * i * i * r + g_shell * room_c) / c_shell;
  }
  double steady_sensor_c(double i, double room_c) const {
    Eigen::Matrix3d a;
    Eigen::Vector3d b;
    network(i, room_c, a, b);
    return Eigen::Vector3d(a.partialPivLu().solve(-b))(1);
  }
  double holding_a(double setpoint_c, double room_c) const {
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < 60; ++k) {
      const double mid = 0.5 * (lo + hi);
      (steady_sensor_c(mid, room_c) < setpoint_c ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  }

  // One second of the network (explicit 0.25 s steps: the fastest node,
  // 60 J/K on 0.65 W/K, has a 90 s time constant) and the sensor's lag.
  void step_1s(double i, double room_c, Eigen::Vector3d& t, double& sensed) const {
    for (int sub = 0; sub < 4; ++sub) {
      Eigen::Matrix3d a;
      Eigen::Vector3d b;
      network(i, room_c, a, b);
      t += 0.25 * (a * t + b);
      sensed += 0.25 / sensor_lag_s * (t(1) - sensed);
    }
  }

  TuneRecord record(double room_c) const {
    TuneRecord out;
    // A shorter experiment (1 h 10 min): relay, PRBS and coast at half length
    // (the whole one takes seconds to identify under the sanitizers).
    tune::ExperimentPlan plan;
    plan.relay_s = 600.0;
    plan.prbs_s = 1200.0;
    plan.coast_s = 600.0;
    tune::IdentificationExperiment experiment(plan);
    Eigen::Vector3d t(room_c, room_c, room_c);
    double sensed = room_c;
    double command = 0.0;
    double noise = 0.0;
    std::mt19937_64 rng(11);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int k = 0;; ++k) {
      const double now = k;
      const double room = room_c + std::sin(now / 7200.0 * 2.0 * 3.14159265358979);
      noise = 0.95 * noise + 0.01 * std::sqrt(1.0 - 0.95 * 0.95) * normal(rng);
      const double reading = test::ds18b20_steps_c(sensed + noise);
      if (k % 2 == 0) {
        control::TecProgramInput in{now, reading, test::ds18b20_steps_c(room), 55.0, -1.0, 1.0};
        const control::TecProgramOutput o = experiment.next(in);
        if (o.finished) break;
        command = o.current_a;
      }
      out.time_s.push_back(now);
      out.sensor_c.push_back(reading);
      out.tec_a.push_back(command);
      out.ambient_c.push_back(test::ds18b20_steps_c(room));
      step_1s(command, room, t, sensed);
    }
    return out;
  }
};

}  // namespace

TEST_CASE("on the plant simulator's experiment the fit reaches the DS18B20's quantisation floor") {
  const ThermalFit& fit = nominal_fit();
  INFO("rms " << fit.rms_c << " C");
  CHECK(fit.rms_c < 1.5 * fit.quantisation_rms_c);
  CHECK(fit.r_squared > 0.9999);
  CHECK(fit.rail_reached);  // the warm-up at full current clips at the OPA548's rails
}

TEST_CASE("the plant simulator's TEC, loss and rail are identified within a few percent") {
  const model::PlantParams p;
  const ThermalFit& fit = nominal_fit();
  CHECK(estimate(fit, "peltier_per_a_s").value == Approx(truth_peltier(p)).epsilon(0.03));
  CHECK(estimate(fit, "joule_k_per_a2_s").value == Approx(truth_joule(p)).epsilon(0.05));
  const double cc = p.casing_capacity_j_per_k + p.die_capacity_j_per_k;
  const double loss = 1.0 / (1.0 / p.shell_ambient_w_per_k + 1.0 / (p.tec_conductance_w_per_k + p.shell_casing_leak_w_per_k)) / cc;
  CHECK(estimate(fit, "loss_per_s").value == Approx(loss).epsilon(0.03));
  CHECK(estimate(fit, "shell_tau_s").value ==
        Approx(p.shell_capacity_j_per_k / (p.shell_ambient_w_per_k + p.tec_conductance_w_per_k + p.shell_casing_leak_w_per_k))
            .epsilon(0.1));
  CHECK(estimate(fit, "rail_a").value == Approx((p.supply_pos_v - p.rail_headroom_v) / p.tec_resistance_ohm).epsilon(0.02));
  // The DS18B20 pipeline: 0.75 s conversion, up to 1 s until the next row.
  CHECK(fit.model.dead_time_s + fit.model.sensor_lag_s > 0.3);
  CHECK(fit.model.dead_time_s + fit.model.sensor_lag_s < 3.0);
}

TEST_CASE("the identified TEC gain is within 0.6 % of the plant simulator's, whose casing node also carries the die") {
  // Not a coverage test: the plant's casing node carries the die (0.5 % of
  // its capacity), a structure the tune model does not have, so the gain is
  // off by more than its standard error (4 se, docs/TUNING.md). What the
  // intervals are worth is measured on records whose truth is the tune model
  // itself (standard_error_coverage_test.cpp, its coverage sweeps).
  const model::PlantParams p;
  const tune::Estimate a = estimate(nominal_fit(), "peltier_per_a_s");
  INFO(a.value << " against " << truth_peltier(p) << ", se " << a.std_error);
  CHECK(std::fabs(a.value - truth_peltier(p)) < 0.006 * truth_peltier(p));
  CHECK(a.std_error > 0.0);
}

TEST_CASE("the loop's unknown heat is at least what the fit leaves unknown of the heat that holds the band's ends") {
  const ThermalFit& fit = nominal_fit();
  const double heat_scale = tune::identified_observer_spec(fit, 55.0, 1.0, 16.0).initial_heat_w / 10.0;
  CHECK(heat_scale >= estimate(fit, "internal_k_per_s").std_error);
  double widest = 0.0;
  for (double ambient_c : {-20.0, 35.0}) {
    const double i = tune::holding_current_a(fit.model, 55.0, ambient_c, 10.0);
    REQUIRE(std::isfinite(i));
    const double current_se =
        tune::std_error_of(fit, [&](const tune::ThermalModel& m) { return tune::holding_current_a(m, 55.0, ambient_c, 10.0); });
    const double gain = tune::casing_gain_k_per_a_s(fit.model, tune::steady_state(fit.model, i, ambient_c), i);
    widest = std::max(widest, current_se * gain);
  }
  CHECK(widest > 0.0);
  CHECK(heat_scale == Approx(std::max(widest, estimate(fit, "internal_k_per_s").std_error)));
  // An internal heat the record pins down exactly: the band's ends set the scale.
  ThermalFit pinned = fit;
  for (tune::Estimate& e : pinned.estimates) {
    if (e.name == "internal_k_per_s") e.std_error = 1e-12;
  }
  CHECK(tune::identified_observer_spec(pinned, 55.0, 1.0, 16.0).initial_heat_w / 10.0 == Approx(widest));
}

TEST_CASE("in a still room the sensor's share of the ambient is not searched: it would be one more static gain") {
  const ThermalFit& fit = nominal_fit();
  CHECK(fit.ambient_range_c < 3.0);
  CHECK_FALSE(fit.sensor_share_fitted);
  CHECK(fit.model.sensor_ambient_share == 0.0);
  CHECK(std::none_of(fit.estimates.begin(), fit.estimates.end(),
                     [](const tune::Estimate& e) { return e.name == "sensor_ambient_share"; }));
}

TEST_CASE("a stage that gives what is commanded gets no current limit of its own") {
  const ThermalFit& fit = nominal_fit();
  CHECK_FALSE(fit.stage_limit_fitted);
  CHECK(std::none_of(fit.estimates.begin(), fit.estimates.end(),
                     [](const tune::Estimate& e) { return e.name == "stage_limit_a"; }));
}

TEST_CASE("a stage whose own limit is below the experiment's commands has that limit identified, and the fit reaches the floor") {
  model::PlantParams p;
  p.current_limit_a = 0.7;  // the OPA548's ILIM below the 1 A the experiment commands
  const ThermalFit fit = tune::identify_thermal(plant_record(p, 16.0, true, 1.0));
  REQUIRE(fit.stage_limit_fitted);
  const tune::Estimate limit = estimate(fit, "stage_limit_a");
  INFO("stage limit " << limit.value << " +/- " << limit.std_error << " A, rms " << fit.rms_c << " C");
  CHECK(limit.value == Approx(0.7).epsilon(0.02));
  CHECK(fit.rms_c < 1.5 * fit.quantisation_rms_c);
  CHECK(estimate(fit, "peltier_per_a_s").value == Approx(truth_peltier(p)).epsilon(0.05));
}

namespace {

// A network plant (model/thermal_network.hpp): the TEC between a heat sink
// and the casing, a heated board of 40 J/K on the casing alone through
// 0.23 W/K (a side node: 1.3e-3/s per the casing's capacity, a 174 s time
// constant), the die on the casing, the DS18B20 on the casing with a 25 s lag.
model::PlantParams board_on_casing_plant() {
  model::PlantParams p;
  model::ThermalNetwork n;
  n.nodes = {{"sink", 190.0, 0.0}, {"casing", 175.0, 0.0}, {"board", 40.0, 0.4}, {"die", 1.7, 0.0}};
  n.links = {{model::kAmbientNode, 0, 0.55}, {0, 1, 0.03}, {1, 2, 0.23}, {1, 3, 0.08}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor = model::NetworkSensor{1, 25.0, 0.0, 0.0};
  n.ambient_sensor = model::NetworkSensor{model::kAmbientNode, 0.0, 0.0, 0.0};
  n.gyro_node = 3;
  p.network = n;
  return p;
}

}  // namespace

TEST_CASE("a board on the casing that the sensor does not see is identified as a side node, and the fit reaches the floor") {
  const ThermalFit fit = tune::identify_thermal(plant_record(board_on_casing_plant(), 16.0));
  REQUIRE(fit.side_fitted);
  const tune::Estimate coupling = estimate(fit, "side_per_s");
  const tune::Estimate tau = estimate(fit, "side_tau_s");
  INFO("side " << coupling.value << " +/- " << coupling.std_error << " /s, tau " << tau.value << " +/- "
               << tau.std_error << " s, lag " << fit.model.sensor_lag_s << " s, rms " << fit.rms_c << " C");
  // Per unit of the casing and the die's capacity (the die rides on the casing).
  CHECK(coupling.value == Approx(0.23 / 176.7).epsilon(0.1));
  CHECK(tau.value == Approx(40.0 / 0.23).epsilon(0.1));
  CHECK(fit.model.sensor_lag_s == Approx(25.0).epsilon(0.1));
  CHECK(fit.rms_c < 1.5 * fit.quantisation_rms_c);
}

TEST_CASE("a record without the ambient column gets no side node: the model-based loop, its one user, needs that column") {
  const ThermalFit fit = tune::identify_thermal(plant_record(board_on_casing_plant(), 22.0, false));
  CHECK_FALSE(fit.side_fitted);
  CHECK(fit.model.side_per_s == 0.0);
}

TEST_CASE("a casing without a side part gets no side node") {
  const ThermalFit& fit = nominal_fit();
  CHECK_FALSE(fit.side_fitted);
  CHECK(fit.model.side_per_s == 0.0);
  CHECK(std::none_of(fit.estimates.begin(), fit.estimates.end(),
                     [](const tune::Estimate& e) { return e.name == "side_per_s"; }));
}

TEST_CASE("a record without the ambient column still identifies the unit, the room as a constant") {
  const ThermalFit fit = tune::identify_thermal(plant_record(model::PlantParams{}, 22.0, false));
  CHECK_FALSE(fit.ambient_measured);
  CHECK(fit.rms_c < 2.0 * fit.quantisation_rms_c);
  // The room and the electronics' heat both set the casing's rest level; what
  // the loop needs, the current that holds the setpoint, comes out right.
  const ThermalFit& with_ambient = nominal_fit();
  CHECK(tune::holding_current_a(fit.model, 55.0, fit.ambient_c, 1.0) ==
        Approx(tune::holding_current_a(with_ambient.model, 55.0, 22.0, 1.0)).epsilon(0.03));
  const tune::Estimate room = estimate(fit, "ambient_c");
  CHECK(std::fabs(room.value - 22.0) < 4.0 * room.std_error + 0.1);
}

namespace {

struct LoopResult {
  double settle_s = -1.0;
  double in_band_c = 0.0;
};

// The Controller's law (control/tec_law.hpp) on the three-node unit, over the
// seed's Fig. 26 programme (data/fig26_chamber_profile.csv) from 16 C.
LoopResult fig26_on(const ThreeNode& unit, const tune::PidGains& gains, double ff_a_per_c,
                    const control::RailLimit& rail) {
  const double programme[][2] = {{0, 16},     {1800, 16},  {2760, 0},   {3960, 0},   {4560, -10}, {5760, -10},
                                 {6360, -20}, {7560, -20}, {8160, -30}, {9360, -30}, {12120, 16}, {13320, 16},
                                 {14460, 35}, {15660, 35}, {16260, 45}, {17460, 45}};
  auto ambient_at = [&](double t) {
    for (std::size_t j = 0; j + 1 < std::size(programme); ++j) {
      if (t < programme[j + 1][0]) {
        return programme[j][1] + (programme[j + 1][1] - programme[j][1]) * (t - programme[j][0]) /
                                     (programme[j + 1][0] - programme[j][0]);
      }
    }
    return 45.0;
  };
  control::PidParams params = control::PidParams::from_gains(gains.kp, gains.ki, gains.kd, 2.0);
  params.xi_c = gains.xi_c;
  params.out_min = -1.0;
  params.out_max = 1.0;
  control::IncrementalPid pid(params);
  Eigen::Vector3d t(16.0, 16.0, 16.0);
  double sensed = 16.0;
  double command = 0.0;
  double ambient_reading = 16.0;
  double band_start = -1.0;
  LoopResult out;
  for (int k = 0; k < 17460; ++k) {
    const double room = ambient_at(k);
    if (k % 10 == 0) ambient_reading = test::ds18b20_steps_c(room);
    if (k % 2 == 0 && k > 0) {
      const double reading = test::ds18b20_steps_c(sensed);
      const control::CurrentRange range = control::applied_range(-1.0, 1.0, rail, reading, ambient_reading);
      command = control::pid_current_a(pid, reading, 55.0, control::feed_forward_a(ff_a_per_c, 55.0, ambient_reading),
                                       range);
    }
    unit.step_1s(command, room, t, sensed);
    const double error = std::fabs(t(1) - 55.0);
    if (out.settle_s < 0.0) {
      band_start = error <= 0.3 ? (band_start < 0.0 ? k : band_start) : -1.0;
      if (band_start >= 0.0 && k - band_start >= 300.0) out.settle_s = band_start;
    } else if (k >= out.settle_s + 300.0 && room >= -20.0 && room <= 35.0) {
      out.in_band_c = std::max(out.in_band_c, error);
    }
  }
  return out;
}

}  // namespace

TEST_CASE("on a three-node casing outside the model's class, tune's loop settles within 30 min and holds the seed's band") {
  // The sensor half lags the TEC half by ~40 s plus its own 8 s: the tune
  // model can only approximate that (a lag on the reading, one casing node),
  // and its holding current and delay come out approximate. What the loop
  // does on the real unit is the test.
  const ThreeNode unit;
  const ThermalFit fit = tune::identify_thermal(unit.record(20.0));
  CHECK(fit.model.dead_time_s + fit.model.sensor_lag_s > 10.0);  // the lags show as delay
  tune::DesignSpec spec;
  spec.room_c = 20.0;
  spec.rail_known = fit.rail_reached;
  const tune::ControllerDesign d = tune::design_controller(fit.model, spec);
  const LoopResult tuned = fig26_on(unit, d.gains, d.feed_forward_a_per_c, d.rail);
  // Seed Eq. 17/18: Kp 0.48, KI 0.32, KD 10, xi 0.5 C, no feed-forward.
  const LoopResult seed = fig26_on(unit, {0.48, 0.32, 10.0, 0.5}, 0.0, {});
  INFO("fit rms " << fit.rms_c << " C; holding current at 20 C: model "
                  << tune::holding_current_a(fit.model, 55.0, 20.0, 1.0) << " A, unit " << unit.holding_a(55.0, 20.0)
                  << " A; tuned (Kp " << d.gains.kp << ", KI " << d.gains.ki << ", KD " << d.gains.kd << "): settled at "
                  << tuned.settle_s << " s, in band " << tuned.in_band_c << " C; seed: settled at " << seed.settle_s
                  << " s, in band " << seed.in_band_c << " C");
  REQUIRE(tuned.settle_s >= 0.0);
  // Measured: settled at 834 s, 0.061 C in band (about one 1/16 C reading
  // step). The bounds leave room for a changed noise draw, not for a loop
  // that hunts over two steps or warms up a third slower.
  CHECK(tuned.settle_s < 1200.0);
  CHECK(tuned.in_band_c <= 0.1);
  CHECK((seed.settle_s < 0.0 || tuned.in_band_c < seed.in_band_c));
  CHECK((seed.settle_s < 0.0 || tuned.settle_s < seed.settle_s));
}

namespace {

TuneRecord ramp_record(std::size_t rows) {
  TuneRecord r;
  for (std::size_t k = 0; k < rows; ++k) {
    r.time_s.push_back(static_cast<double>(k));
    r.sensor_c.push_back(20.0 + 0.01 * static_cast<double>(k % 600));
    r.tec_a.push_back((k / 300) % 2 == 0 ? 0.5 : -0.5);
    r.ambient_c.push_back(20.0);
  }
  return r;
}

std::string error_of(const TuneRecord& r) {
  try {
    (void)tune::identify_thermal(r);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("a record shorter than 30 min is refused, saying how long it is and what is needed") {
  const std::string why = error_of(ramp_record(600));
  CHECK(why.find("lasts 599 s") != std::string::npos);
  CHECK(why.find("at least 30 min") != std::string::npos);
}

TEST_CASE("the shortest record accepted scales with the experiment's time scale") {
  std::string why;
  try {
    (void)tune::identify_thermal(ramp_record(150), 0.1);
  } catch (const std::invalid_argument& e) {
    why = e.what();
  }
  CHECK(why.find("at least 180 s") != std::string::npos);
  try {
    (void)tune::identify_thermal(ramp_record(600), 0.1);  // long enough at this scale: what follows is checked
    why.clear();
  } catch (const std::invalid_argument& e) {
    why = e.what();
  }
  CHECK(why.find("lasts") == std::string::npos);
}

TEST_CASE("a record whose current never changes is refused as without excitation") {
  TuneRecord r = ramp_record(4000);
  std::fill(r.tec_a.begin(), r.tec_a.end(), 0.3);
  CHECK(error_of(r).find("no excitation") != std::string::npos);
}

TEST_CASE("a record whose casing does not move is refused as flat") {
  TuneRecord r = ramp_record(4000);
  std::fill(r.sensor_c.begin(), r.sensor_c.end(), 21.0625);
  CHECK(error_of(r).find("flat record") != std::string::npos);
}

TEST_CASE("a record with the current at its limit nearly all the time is refused as saturated") {
  TuneRecord r = ramp_record(4000);
  for (std::size_t k = 0; k < r.tec_a.size(); ++k) r.tec_a[k] = k < 200 ? 0.0 : 1.0;
  CHECK(error_of(r).find("saturated experiment") != std::string::npos);
}

TEST_CASE("a record with the casing sensor at the end of its range is refused as saturated") {
  TuneRecord r = ramp_record(4000);
  r.sensor_c[100] = 125.0;
  CHECK(error_of(r).find("DS18B20's end of range") != std::string::npos);
}

TEST_CASE("a record with a gap or time going back is refused, naming where") {
  TuneRecord gap = ramp_record(4000);
  for (std::size_t k = 2000; k < gap.time_s.size(); ++k) gap.time_s[k] += 120.0;
  CHECK(error_of(gap).find("a gap of 121 s") != std::string::npos);
  TuneRecord back = ramp_record(4000);
  back.time_s[50] = back.time_s[49];
  CHECK(error_of(back).find("time_s does not increase at row 51") != std::string::npos);
}

TEST_CASE("a record where the current has no effect on the casing is refused") {
  // The casing follows a slow random walk of its own; the current switches.
  TuneRecord r;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> step(0.0, 0.02);
  double t = 30.0;
  for (int k = 0; k < 2400; ++k) {
    t += step(rng);
    r.time_s.push_back(k);
    r.sensor_c.push_back(test::ds18b20_steps_c(t));
    r.tec_a.push_back((k / 45) % 3 == 0 ? 0.6 : -0.2);
    r.ambient_c.push_back(20.0);
  }
  CHECK(error_of(r).find("no measurable effect") != std::string::npos);
}

TEST_CASE("a record whose current runs against the casing is refused as a TEC wired the wrong way round, not as a current without effect") {
  // What the board logged while the TEC pumped the other way (the experiment
  // stops such a unit in its approach, experiment_test.cpp; a unit started
  // at the setpoint skips that check).
  TuneRecord r = plant_record(model::PlantParams{}, 16.0);
  for (double& i : r.tec_a) i = -i;
  const std::string why = error_of(r);
  INFO(why);
  CHECK(why.find("wired the wrong way round") != std::string::npos);
}
