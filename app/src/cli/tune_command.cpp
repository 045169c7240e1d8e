// `gyrotc tune`: the unit's own temperature loop from its identification
// record (issue 23). Identifies the thermal model from time_s, sensor_c,
// tec_a (and ambient_c), designs the controller with a stated robustness
// margin, writes the controller file and prints the report.

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/output_path.hpp"
#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc/app/workflows/tuning.hpp"

namespace gyrotc::app {
namespace {

struct TuneOptions {
  std::string data;
  std::string out;
  std::string plot;
  std::optional<double> setpoint_c;
  double experiment_scale = 1.0;
  std::string loop = "pid";
  bool json = false;
};

// The record's casing reading (wide, light) under the identified model's
// (thin, dark), the residual between them, and the current that drove both.
plot::Figure fit_figure(const TuneInput& in, const TuneResult& r) {
  plot::Figure f;
  f.title = "gyrotc tune: the identified model against " + in.source;
  f.x.title = "time (s)";
  f.x.tight = true;
  f.panel_height_px = 200.0;
  plot::Series measured{"casing reading (record)", in.record.time_s, in.record.sensor_c, "#9ecae1"};
  measured.width_px = 5.0;
  plot::Series model{"model", in.record.time_s, r.fit.prediction, "#d62728"};
  plot::Series current{"TEC current (commanded)", in.record.time_s, in.record.tec_a, "#ff7f0e"};
  plot::Series residual{"record - model", in.record.time_s, {}, "#555555"};
  for (std::size_t k = 0; k < in.record.time_s.size(); ++k) residual.y.push_back(in.record.sensor_c[k] - r.fit.prediction[k]);
  plot::Panel top;
  top.y.title = "casing (°C)";
  top.series = {measured, model};
  plot::Panel middle;
  middle.y.title = "residual (°C)";
  middle.series = {residual};
  plot::Panel bottom;
  bottom.y.title = "TEC (A)";
  bottom.series = {current};
  f.panels = {top, middle, bottom};
  return f;
}

void print_pid(const nlohmann::json& d, const char* title) {
  auto num = [](const nlohmann::json& v, const char* format) {
    if (v.is_null()) return std::string("n/a");
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v.get<double>());
    return std::string(buf);
  };
  std::printf("  %s: Kp %.4g, KI %.4g, KD %.4g (T %.3g s), xi %.3g C, feed-forward %.5g A/C through a %.0f s "
              "lag, setpoint ramp %.3g C/s\n",
              title, d["kp"].get<double>(), d["ki"].get<double>(), d["kd"].get<double>(), d["period_s"].get<double>(),
              d["xi_c"].get<double>(), d["feed_forward_a_per_c"].get<double>(), d["feed_forward_lag_s"].get<double>(),
              d["setpoint_ramp_c_per_s"].get<double>());
  if (!d["rail"].is_null()) {
    std::printf("  rail limit: %.4g A - %.4g A/C x (casing - ambient); stuck-sensor drive threshold %.3g A\n",
                d["rail"]["pos_a"].get<double>(), d["rail"]["a_per_c"].get<double>(), d["stuck_min_drive_a"].get<double>());
  } else {
    std::printf("  rail limit: not identified; stuck-sensor drive threshold %.3g A\n", d["stuck_min_drive_a"].get<double>());
  }
  const auto& m = d["margins"];
  std::printf("  robustness: Ms %.2f (limit %.2f), gain margin %s, phase margin %s deg, crossover %.3g rad/s\n",
              m["max_sensitivity"].get<double>(), m["max_sensitivity_limit"].get<double>(),
              num(m["gain_margin"], "%.2f").c_str(), num(m["phase_margin_deg"], "%.0f").c_str(),
              m["crossover_rad_s"].get<double>());
  for (const auto& p : m["perturbed"]) {
    std::printf("    %-20s Ms %.2f (limit %.2f)\n", p["perturbation"].get<std::string>().c_str(),
                p["max_sensitivity"].get<double>(), m["max_sensitivity_perturbed_limit"].get<double>());
  }
  std::printf("  predicted on the model: settles in %s s from %.1f C (physical minimum %s s), |error| <= %.3f C for "
              "ambient -20..35 C\n",
              num(d["predicted_settle_s"], "%.0f").c_str(), d["room_c"].get<double>(),
              num(d["minimum_settle_s"], "%.0f").c_str(), d["predicted_max_error_in_band_c"].get<double>());
}

void print_text(const nlohmann::json& j, const std::string& source, const std::string& out) {
  auto num = [](const nlohmann::json& v, const char* format) {
    if (v.is_null()) return std::string("n/a");
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v.get<double>());
    return std::string(buf);
  };
  std::printf("gyrotc tune: %s (%zu rows, %.0f s) -> %s\n", source.c_str(), j["samples"].get<std::size_t>(),
              j["duration_s"].get<double>(), out.c_str());
  const auto& fit = j["fit"];
  std::printf("  fit: rms %.4f C (DS18B20 quantisation %.4f C), max %.3f C, R^2 %.6f, lag-1 %.2f, Ljung-Box p %.2g\n",
              fit["rms_c"].get<double>(), fit["quantisation_rms_c"].get<double>(), fit["max_abs_c"].get<double>(),
              fit["r_squared"].get<double>(), fit["lag1_autocorrelation"].get<double>(),
              fit["ljung_box_p"].get<double>());
  std::printf("  residual noise the standard errors assume: white %.4f C + %.4f C with a %.0f s time constant",
              fit["noise_white_c"].get<double>(), fit["noise_slow_c"].get<double>(), fit["noise_slow_tau_s"].get<double>());
  if (fit["noise_slower_c"].get<double>() > 0.0) {
    std::printf(" + %.4f C with %.0f s", fit["noise_slower_c"].get<double>(), fit["noise_slower_tau_s"].get<double>());
  }
  std::printf("\n");
  std::printf("  identified (per unit of casing heat capacity; +/- one standard error):\n");
  for (const auto& p : j["parameters"]) {
    std::printf("    %-28s %12s +/- %-10s %-10s %s\n", p["name"].get<std::string>().c_str(), num(p["value"], "%.5g").c_str(),
                num(p["std_error"], "%.2g").c_str(), p["unit"].get<std::string>().c_str(),
                p["determined"].get<bool>() ? "" : p["note"].get<std::string>().c_str());
  }
  for (const auto& p : j["derived"]) {
    std::printf("    %-28s %12s +/- %-10s %s\n", p["name"].get<std::string>().c_str(), num(p["value"], "%.5g").c_str(),
                num(p["std_error"], "%.2g").c_str(), p["unit"].get<std::string>().c_str());
  }
  if (!j["observer"].is_null()) {
    const auto& o = j["observer"];
    std::printf("  model-based loop (type = \"observer\"): %d states (casing, shell%s%s%s), period %.3g s; at the "
                "design point it holds %.3f A, the filter's spectral radius %.4f, the loop's %.4f (stable below 1)\n",
                o["states"].get<int>(), o["sensor_node"].get<bool>() ? ", the sensor's node" : "",
                o["sensor_lag_s"].get<double>() > 0.0 ? ", the sensor's lag" : "",
                o["side_node"].get<bool>() ? ", a side node on the casing" : "", o["period_s"].get<double>(),
                o["operating_current_a"].get<double>(), o["observer_spectral_radius"].get<double>(),
                o["loop_spectral_radius"].get<double>());
    std::printf("  readings taken as 1/16 C steps with %.4f C of noise; stuck-sensor drive threshold %.3g A\n",
                o["reading_noise_c"].get<double>(), o["stuck_min_drive_a"].get<double>());
  }
  if (!j["design"].is_null()) print_pid(j["design"], j["observer"].is_null() ? "controller" : "PID (for comparison)");
  for (const auto& w : j["warnings"]) std::printf("  warning: %s\n", w.get<std::string>().c_str());
  std::printf("  took %.3f s (identify %.3f s, design %.3f s)\n",
              j["identify_s"].get<double>() + j["design_s"].get<double>(), j["identify_s"].get<double>(),
              j["design_s"].get<double>());
}

void run(const TuneOptions& o) {
  // The outputs first: nothing is computed for a file that cannot be written.
  prepare_output_file(o.out, "--out");
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  TuneInput input = read_tune_record(o.data);
  if (o.setpoint_c) input.setpoint_c = *o.setpoint_c;
  input.experiment_scale = o.experiment_scale;
  input.loop = o.loop == "observer" ? TuneLoop::observer : TuneLoop::pid;
  const TuneResult result = tune_from_record(input);
  save_controller_file(result.controller, o.out, tune_informational_toml(result, o.data));
  nlohmann::json j = tune_json(result);
  j["data"] = o.data;
  j["controller_file"] = o.out;
  if (!o.plot.empty()) {
    plot::write_svg(fit_figure(input, result), o.plot);
    j["plot"] = o.plot;
  }
  if (o.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    print_text(j, o.data, o.out);
  }
}

}  // namespace

void add_tune_command(CLI::App& app) {
  auto options = std::make_shared<TuneOptions>();
  CLI::App* cmd = app.add_subcommand(
      "tune",
      "Design the unit's own temperature loop from its identification record. From a record of\n"
      "`gyrotc record --experiment tune` or `gyrotc simulate --profile tune` (time_s, sensor_c, tec_a\n"
      "and ambient_c only) it identifies the thermal model (TEC Peltier and Joule terms, casing and\n"
      "shell, sensor lag and dead time, the OPA548 rail), reports it with uncertainties and fit quality,\n"
      "designs the loop, and writes a controller file for `gyrotc simulate --controller FILE`,\n"
      "`gyrotc run --controller FILE` or [control] controller_file. --loop pid: the PID (gains,\n"
      "separation band, feed-forward, anti-windup rail limit) for a maximum sensitivity Ms <= 1.6;\n"
      "--loop observer: a Kalman filter on the identified housing with LQ feedback, one reading per\n"
      "second (docs/TUNING.md).");
  cmd->add_option("--data", options->data, "the identification record (CSV)")->required();
  cmd->add_option("--out", options->out, "the controller file to write (TOML)")->required();
  cmd->add_option("--setpoint-c", options->setpoint_c,
                  "casing setpoint to design for (default: the record's setpoint_c, else 55 C)");
  cmd->add_option("--experiment-scale", options->experiment_scale,
                  "the record is an experiment shortened by this factor (record --experiment-scale): the shortest "
                  "record accepted, 30 min, scales with it")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  cmd->add_option("--plot", options->plot, "SVG plot: the record's reading against the model's, and the residual")
      ->check([](const std::string& p) {
        return p.size() >= 4 && p.compare(p.size() - 4, 4, ".svg") == 0 ? std::string() : "only .svg is supported";
      });
  cmd->add_option("--loop", options->loop,
                  "the loop to design: pid (the seed's integral-separated PID with tuned gains) or observer (a "
                  "Kalman filter on the identified housing with LQ feedback, docs/TUNING.md)")
      ->check(CLI::IsMember({"pid", "observer"}))
      ->capture_default_str();
  cmd->add_flag("--json", options->json, "print the report as one JSON object");
  cmd->callback([options] { run(*options); });
}

}  // namespace gyrotc::app
