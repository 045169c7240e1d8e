#include "gyrotc/app/workflows/tuning.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <stdexcept>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/tune/identified_housing.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/stopwatch.hpp"

namespace gyrotc::app {
namespace {

constexpr const char* kNeeds =
    "gyrotc tune needs time_s, sensor_c and tec_a (and ambient_c when the board has an ambient sensor), as "
    "`gyrotc record --experiment tune` and `gyrotc simulate --profile tune` write them";

// The model-based loop's period: one casing reading per period, the
// DS18B20's own rate (its conversion takes 750 ms).
constexpr double kObserverPeriodS = 1.0;

std::string fmt(const char* format, double a, double b = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b);
  return buf;
}

std::string toml_number(double v) {
  if (!std::isfinite(v)) return v > 0 ? "inf" : (v < 0 ? "-inf" : "nan");
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  std::string s(buf);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

// Room temperature of the record: the mean ambient reading, or the estimate.
double room_of(const tune::TuneRecord& r, const tune::ThermalFit& fit) {
  double sum = 0.0;
  std::size_t n = 0;
  for (double a : r.ambient_c) {
    if (std::isfinite(a)) {
      sum += a;
      ++n;
    }
  }
  return n > 0 ? sum / static_cast<double>(n) : fit.ambient_c;
}

}  // namespace

TuneInput read_tune_record(const std::string& path) {
  const CsvTable table = CsvTable::read(path);
  for (const char* column : {"time_s", "sensor_c", "tec_a"}) {
    if (!table.has(column)) throw InputError(path + ": no column '" + column + "': " + kNeeds);
  }
  TuneInput in;
  in.source = path;
  in.record.time_s = table.numbers("time_s");
  in.record.sensor_c = table.numbers("sensor_c");
  in.record.tec_a = table.numbers("tec_a");
  if (table.has("ambient_c")) {
    in.record.ambient_c = table.numbers_or_nan("ambient_c");
    if (std::none_of(in.record.ambient_c.begin(), in.record.ambient_c.end(), [](double v) { return std::isfinite(v); })) {
      in.record.ambient_c.clear();  // a board without the ambient sensor writes nan
    }
  }
  if (table.has("setpoint_c")) {
    std::vector<double> sp = table.numbers_or_nan("setpoint_c");
    sp.erase(std::remove_if(sp.begin(), sp.end(), [](double v) { return !std::isfinite(v); }), sp.end());
    if (!sp.empty()) {
      std::nth_element(sp.begin(), sp.begin() + static_cast<std::ptrdiff_t>(sp.size() / 2), sp.end());
      in.setpoint_c = sp[sp.size() / 2];
    }
  }
  if (in.record.time_s.empty()) throw InputError(path + ": no rows: " + kNeeds);
  return in;
}

TuneResult tune_from_record(const TuneInput& input) {
  TuneResult r;
  auto start = std::chrono::steady_clock::now();
  try {
    r.fit = tune::identify_thermal(input.record, input.experiment_scale);
  } catch (const std::invalid_argument& e) {
    throw InputError(input.source + ": " + e.what());
  }
  r.identify_s = seconds_since(start);

  r.spec.setpoint_c = input.setpoint_c;
  r.spec.room_c = room_of(input.record, r.fit);
  r.spec.ambient_sensor = r.fit.ambient_measured;
  // The current that flows: the commands, within the stage's own limit where
  // the record shows one below them.
  r.spec.max_a = std::min(r.fit.heating_limit_a, r.fit.model.stage_limit_a);
  r.spec.min_a = std::min(std::max(r.fit.cooling_limit_a, -r.fit.model.stage_limit_a), -1e-3);
  r.spec.rail_known = r.fit.rail_reached;
  for (const auto& e : r.fit.estimates) {
    if (e.name == "shell_ratio" || e.name == "shell_tau_s") r.spec.shell_known = r.spec.shell_known && e.determined;
  }
  start = std::chrono::steady_clock::now();
  try {
    r.design = tune::design_controller(r.fit.lumped_model, r.spec);
    r.pid_designed = true;
  } catch (const std::invalid_argument& e) {
    if (input.loop == TuneLoop::pid) throw InputError(input.source + ": " + e.what());
    r.warnings.push_back(std::string("the PID (for comparison; --loop pid): ") + e.what());
  }

  ControllerFile& c = r.controller;
  c.setpoint_c = input.setpoint_c;
  if (input.loop == TuneLoop::observer) {
    if (!r.fit.ambient_measured) {
      throw InputError(input.source + ": --loop observer needs the ambient sensor's readings (no ambient_c column): "
                       "the model-based loop takes the ambient as a measured input; --loop pid works without");
    }
    ObserverLoopFile o;
    o.model = r.fit.model;
    o.spec = tune::identified_observer_spec(r.fit, input.setpoint_c, kObserverPeriodS, r.spec.room_c);
    try {
      r.observer = std::make_shared<const control::ObserverLoopDesign>(control::design_observer_loop(
          tune::identified_housing(o.model, std::max(r.spec.max_a, -r.spec.min_a)), o.spec));
    } catch (const std::invalid_argument& e) {
      throw InputError(input.source + ": " + e.what());
    }
    c.period_s = kObserverPeriodS;
    c.observer = o;
    c.stuck_min_drive_a = tune::stuck_min_drive_a(r.fit.model, r.spec);
  } else {
    c.kp = r.design.gains.kp;
    c.ki = r.design.gains.ki;
    c.kd = r.design.gains.kd;
    c.period_s = r.spec.period_s;
    c.xi_c = r.design.gains.xi_c;
    c.feed_forward_a_per_c = r.design.feed_forward_a_per_c;
    c.feed_forward_lag_s = r.design.feed_forward_lag_s;
    c.setpoint_ramp_c_per_s = r.design.setpoint_ramp_c_per_s;
    c.rail = r.design.rail;
    c.stuck_min_drive_a = r.design.stuck_min_drive_a;
  }
  r.design_s = seconds_since(start);

  // What the user should know.
  double lowest = std::numeric_limits<double>::quiet_NaN();
  double highest = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t j = 0; j < r.design.holding_ambient_c.size(); ++j) {
    if (!std::isfinite(r.design.holding_a[j])) continue;
    const double ta = r.design.holding_ambient_c[j];
    if (!std::isfinite(lowest)) lowest = ta;
    highest = ta;
  }
  if (lowest > r.spec.rated_low_c || highest < r.spec.rated_high_c) {
    r.warnings.push_back(fmt("the unit can hold the setpoint only for ambients of about %.0f .. %.0f C with its "
                             "current limits and rails",
                             lowest, highest));
  }
  if (!r.fit.rail_reached && input.loop == TuneLoop::pid) {
    r.warnings.push_back("the experiment never reached the OPA548's rail limit: no [rail] in the controller file, "
                         "the anti-windup knows only the current limits");
  }
  // A limit within 3 % of the largest command changes little and is no cause
  // to configure less (tune_suite: stages that gave the whole command were
  // fitted limits of 97..99 % of it, docs/TUNING.md section 2).
  if (r.fit.stage_limit_fitted && r.fit.model.stage_limit_a < 0.97 * r.fit.max_command_a) {
    r.warnings.push_back(fmt("the stage gave at most %.3f A, below the %.3f A commanded (the OPA548's own current "
                             "limit, its ILIM): the loop is designed for it; ",
                             r.fit.model.stage_limit_a, r.fit.max_command_a) +
                         fmt("set [tec] current_limit_a to %.2f A or less, so that the limit the daemon applies "
                             "and reports is the one that acts",
                             std::floor(100.0 * r.fit.model.stage_limit_a) / 100.0));
  }
  if (!r.fit.ambient_measured) {
    r.warnings.push_back(fmt("no ambient column: no feed-forward; the ambient was taken constant at %.1f C",
                             r.fit.ambient_c));
  } else if (!r.fit.sensor_share_fitted && r.fit.ambient_range_c < 3.0) {
    // thermal_identify.cpp: the share is searched only where the room moved.
    r.warnings.push_back(fmt("the room stayed within %.1f C over the record", r.fit.ambient_range_c) +
                         ": how a change of the room reaches the casing sensor other than through the housing "
                         "is not known, and the loop learns it only through its integral; where the ambient "
                         "DS18B20 reads the room (not the heat sink), a chamber step of about 10 C once the unit "
                         "holds the setpoint lets tune identify it (docs/TUNING.md, section 1)");
  }
  if (r.fit.rms_c > 2.0 * r.fit.quantisation_rms_c) {
    // What the suite found outside the model's class (docs/TUNING.md, limits).
    r.warnings.push_back(fmt("the model misses part of the record: residual rms %.3f C, %.1fx the DS18B20's "
                             "quantisation",
                             r.fit.rms_c, r.fit.rms_c / r.fit.quantisation_rms_c) +
                         "; known causes (docs/TUNING.md, limits): a sensor on a node of its own, "
                         "a slow mode inside the casing" +
                         (r.fit.ambient_range_c >= 3.0
                              ? fmt(", an ambient DS18B20 on the heat sink (its reading moved by %.1f C; a "
                                    "chamber's step makes that worse: record in a still room)",
                                    r.fit.ambient_range_c)
                              : std::string()));
  }
  const double max_sensor = *std::max_element(input.record.sensor_c.begin(), input.record.sensor_c.end());
  const double min_sensor = *std::min_element(input.record.sensor_c.begin(), input.record.sensor_c.end());
  if (max_sensor < input.setpoint_c - 1.0 || min_sensor > input.setpoint_c + 1.0) {
    r.warnings.push_back(fmt("the record never came within 1 C of the setpoint (%.1f C): the model is "
                             "extrapolated there",
                             input.setpoint_c));
  }
  for (const auto& e : r.fit.estimates) {
    if (!e.determined && e.name != "rail_a") r.warnings.push_back(e.name + ": " + e.note);
  }
  return r;
}

SimulationResult simulate_tune_experiment(const model::PlantParams& plant, double room_c, double sample_rate_hz,
                                          const tune::ExperimentPlan& plan, double configured_limit_a,
                                          double ambient_step_c) {
  static const fit::BiasModel calibration = fit::BiasModel::paper_reference();
  SimulationSetup s;
  s.plant = plant;
  s.controller = controller_preset(ControllerMode::paper, plant);  // its limits and fail-safes; the PID idles
  if (configured_limit_a > 0.0) {
    s.controller.pid.out_min = -configured_limit_a;
    s.controller.pid.out_max = configured_limit_a;
  }
  s.calibration = &calibration;
  s.sample_rate_hz = sample_rate_hz;
  tune::IdentificationExperiment experiment(plan);
  s.program = &experiment;
  return run_simulation(s, tune_experiment_room(room_c, plan, ambient_step_c));
}

double ambient_step_at_s(const tune::ExperimentPlan& plan) { return plan.rest_s + plan.approach_timeout_s; }

model::ChamberProfile tune_experiment_room(double room_c, const tune::ExperimentPlan& plan, double ambient_step_c) {
  const double end_s = plan.max_duration_s();
  if (ambient_step_c == 0.0) return model::ChamberProfile({{"tune", 0.0, end_s, room_c, room_c}});
  constexpr double kChamberRampCPerS = 1.0 / 60.0;  // data/README.md: 1 C/min
  const double at_s = ambient_step_at_s(plan);
  const double ramped_s = at_s + std::fabs(ambient_step_c) / kChamberRampCPerS;
  const double to_c = room_c + ambient_step_c;
  return model::ChamberProfile({{"tune", 0.0, at_s, room_c, room_c},
                                {"step", at_s, ramped_s, room_c, to_c},
                                {"tune, stepped", ramped_s, std::max(end_s, ramped_s + 1.0), to_c, to_c}});
}

double plant_minimum_warm_up_s(const model::PlantParams& params, double from_c, double target_c) {
  model::PlantParams p = params;
  p.initial_temp_c = from_c;
  model::Plant plant(p, 1);
  plant.set_ambient_c(from_c);
  plant.set_tec_enabled(true);
  plant.set_tec_drive_v(model::stage_drive_v(p, p.current_limit_a));
  constexpr double kStepS = 0.1;
  for (double t = 0.0; t < 4.0 * 3600.0; t += kStepS) {
    if (plant.controlled_c() >= target_c) return t;
    plant.advance(kStepS);
  }
  return -1.0;
}

std::string tune_informational_toml(const TuneResult& r, const std::string& source) {
  std::string out = "[identified]          # gyrotc tune from " + source + " (informational, not read)\n";
  for (const auto& e : r.fit.estimates) {
    out += e.name + " = " + toml_number(e.value) + "\n";
    out += e.name + "_std = " + toml_number(e.std_error) + "\n";
  }
  out += "fit_rms_c = " + toml_number(r.fit.rms_c) + "\n";
  out += "samples = " + std::to_string(r.fit.samples) + "\n";
  if (r.observer) {
    const control::ObserverLoopDesign& d = *r.observer;
    out += "\n[design]              # the model-based loop at the design point (informational, not read)\n";
    out += "operating_current_a = " + toml_number(d.operating_current_a) + "\n";
    out += "feedback_a_per_c = [";
    for (Eigen::Index k = 0; k < d.feedback.size(); ++k) out += (k > 0 ? ", " : "") + toml_number(d.feedback(k));
    out += "]   # per state: casing, shell, the sensor's node (a lag in the record), the sensor's own lag\n";
    out += "observer_spectral_radius = " + toml_number(d.observer_radius) + "\n";
    out += "loop_spectral_radius = " + toml_number(d.loop_radius) + "\n";
    out += "room_c = " + toml_number(r.spec.room_c) + "\n";
    return out;
  }
  out += "\n[design]              # robustness margin and what the design predicts (informational, not read)\n";
  out += "max_sensitivity = " + toml_number(r.design.margins.max_sensitivity) + "\n";
  out += "gain_margin = " + toml_number(r.design.margins.gain_margin) + "\n";
  out += "phase_margin_deg = " + toml_number(r.design.margins.phase_margin_deg) + "\n";
  out += "max_sensitivity_limit = " + toml_number(r.spec.max_sensitivity) + "\n";
  for (const auto& p : r.design.perturbed) {
    std::string key = "max_sensitivity_" + p.perturbation;
    for (char& ch : key) {
      if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    }
    out += key + " = " + toml_number(p.max_sensitivity) + "\n";
  }
  out += "predicted_settle_s = " + toml_number(r.design.predicted.settle_s) + "\n";
  out += "minimum_settle_s = " + toml_number(r.design.minimum_settle_s) + "\n";
  out += "predicted_max_error_in_band_c = " + toml_number(r.design.predicted.max_error_in_band_c) + "\n";
  out += "room_c = " + toml_number(r.spec.room_c) + "\n";
  return out;
}

nlohmann::json tune_json(const TuneResult& r) {
  using nlohmann::json;
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  const auto& f = r.fit;
  j["samples"] = f.samples;
  j["duration_s"] = f.duration_s;
  j["identify_s"] = r.identify_s;
  j["design_s"] = r.design_s;
  const double row_s = f.duration_s / static_cast<double>(std::max<std::size_t>(1, f.samples - 1));
  j["fit"] = {{"rms_c", f.rms_c},
              {"max_abs_c", f.max_abs_c},
              {"quantisation_rms_c", f.quantisation_rms_c},
              {"r_squared", f.r_squared},
              {"lag1_autocorrelation", f.lag1_autocorrelation},
              {"effective_samples", f.effective_samples},
              {"noise_white_c", std::sqrt(f.noise.white_var)},
              {"noise_slow_c", std::sqrt(f.noise.slow_var)},
              {"noise_slow_tau_s", f.noise.slow_tau_rows * row_s},
              {"noise_slower_c", std::sqrt(f.noise.slower_var)},
              {"noise_slower_tau_s", f.noise.slower_tau_rows * row_s},
              {"ljung_box_p", f.ljung_box_p},
              {"ambient_measured", f.ambient_measured},
              {"rail_reached", f.rail_reached},
              {"sensor_share_fitted", f.sensor_share_fitted},
              {"stage_limit_fitted", f.stage_limit_fitted},
              {"side_fitted", f.side_fitted}};
  json params = json::array();
  for (const auto& e : f.estimates) {
    params.push_back({{"name", e.name},
                      {"unit", e.unit},
                      {"value", number(e.value)},
                      {"std_error", number(e.std_error)},
                      {"determined", e.determined},
                      {"note", e.note}});
  }
  j["parameters"] = params;
  const double sp = r.spec.setpoint_c;
  const double room = r.spec.room_c;
  const double limit = std::max(r.spec.max_a, -r.spec.min_a);
  auto hold_at = [sp, limit](double ta) {
    return [sp, limit, ta](const tune::ThermalModel& m) { return tune::holding_current_a(m, sp, ta, limit); };
  };
  auto gain_at_setpoint = [sp, room, limit](const tune::ThermalModel& m) {
    const double i = tune::holding_current_a(m, sp, room, limit);
    return tune::casing_gain_k_per_a_s(m, tune::steady_state(m, i, room), i);
  };
  auto time_constant = [](const tune::ThermalModel& m) { return 1.0 / m.loss_per_s; };
  auto derived = [&](const char* name, const char* unit, const std::function<double(const tune::ThermalModel&)>& fn) {
    return json{{"name", name}, {"unit", unit}, {"value", number(fn(f.model))}, {"std_error", number(tune::std_error_of(f, fn))}};
  };
  j["derived"] = json::array({derived("casing_time_constant_s", "s", time_constant),
                              derived("tec_gain_at_setpoint_k_per_a_s", "K/(A s)", gain_at_setpoint),
                              derived("holding_a_at_band_low", "A", hold_at(r.spec.band_low_c)),
                              derived("holding_a_at_room", "A", hold_at(room)),
                              derived("holding_a_at_band_high", "A", hold_at(r.spec.band_high_c))});
  json holding = json::array();
  for (std::size_t k = 0; k < r.design.holding_ambient_c.size(); ++k) {
    holding.push_back({{"ambient_c", r.design.holding_ambient_c[k]}, {"current_a", number(r.design.holding_a[k])}});
  }
  j["holding"] = holding;
  const auto& d = r.design;
  json perturbed = json::array();
  for (const auto& p : d.perturbed) perturbed.push_back({{"perturbation", p.perturbation}, {"max_sensitivity", p.max_sensitivity}});
  if (r.pid_designed) {
    j["design"] = {{"setpoint_c", sp},
                   {"kp", d.gains.kp},
                   {"ki", d.gains.ki},
                   {"kd", d.gains.kd},
                   {"period_s", r.spec.period_s},
                   {"xi_c", d.gains.xi_c},
                   {"feed_forward_a_per_c", d.feed_forward_a_per_c},
                   {"feed_forward_lag_s", d.feed_forward_lag_s},
                   {"setpoint_ramp_c_per_s", d.setpoint_ramp_c_per_s},
                   {"stuck_min_drive_a", d.stuck_min_drive_a},
                   {"rail", d.rail.known ? json{{"pos_a", d.rail.pos_a}, {"neg_a", d.rail.neg_a}, {"a_per_c", d.rail.a_per_c}}
                                         : json(nullptr)},
                   {"room_c", room},
                   {"current_limits_a", {r.spec.min_a, r.spec.max_a}},
                   {"margins",
                    {{"max_sensitivity", d.margins.max_sensitivity},
                     {"max_sensitivity_limit", r.spec.max_sensitivity},
                     {"gain_margin", number(d.margins.gain_margin)},
                     {"phase_margin_deg", number(d.margins.phase_margin_deg)},
                     {"crossover_rad_s", d.margins.crossover_rad_s},
                     {"perturbed", perturbed},
                     {"max_sensitivity_perturbed_limit", r.spec.max_sensitivity_perturbed}}},
                   {"predicted_settle_s", number(d.predicted.settle_s)},
                   {"minimum_settle_s", number(d.minimum_settle_s)},
                   {"predicted_max_error_in_band_c", d.predicted.max_error_in_band_c},
                   {"candidates", d.candidates},
                   {"robust_candidates", d.robust_candidates}};
  } else {
    j["design"] = nullptr;
  }
  j["loop"] = r.observer ? "observer" : "pid";
  if (r.observer) {
    const control::ObserverLoopDesign& o = *r.observer;
    std::vector<double> feedback(o.feedback.data(), o.feedback.data() + o.feedback.size());
    j["observer"] = {{"setpoint_c", sp},
                     {"period_s", o.spec.period_s},
                     {"states", o.model.state_count()},
                     {"sensor_node", o.model.network.casing_sensor.node != 0},
                     {"sensor_lag_s", o.model.network.casing_sensor.tau_s},
                     {"side_node", r.fit.side_fitted},
                     {"operating_current_a", o.operating_current_a},
                     {"feedback_a_per_c", feedback},
                     {"observer_spectral_radius", o.observer_radius},
                     {"loop_spectral_radius", o.loop_radius},
                     {"reading_noise_c", o.spec.reading_noise_c},
                     {"stuck_min_drive_a", r.controller.stuck_min_drive_a.value_or(0.0)},
                     {"current_limits_a", {r.spec.min_a, r.spec.max_a}}};
  } else {
    j["observer"] = nullptr;
  }
  j["warnings"] = r.warnings;
  return j;
}

}  // namespace gyrotc::app
