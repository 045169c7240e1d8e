// `gyrotc identify`: the discrepancy workflow (issue 8) on a recorded or
// simulated time series, or on the static characteristics of seed Table 1.
// Reads the CSV, runs gyrotc::identify, prints a summary or JSON, and writes
// the optional Markdown report and the plant description with the effects on.

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/separating_experiment.hpp"
#include "gyrotc/algorithms/identify/series_identify.hpp"
#include "gyrotc/algorithms/identify/static_identify.hpp"
#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc/app/support/progress.hpp"
#include "gyrotc/app/support/stopwatch.hpp"
#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc/app/support/output_path.hpp"

namespace gyrotc::app {
namespace {

namespace id = gyrotc::identify;

struct IdentifyOptions {
  std::string data;
  std::string target;
  std::string plant;
  std::string report_dir;
  std::string out_plant;
  bool json = false;
  double r_th_k_per_w = 0.0;  // 0: from the plant (--plant, else its defaults)
};

bool is_static_target(const std::string& t) {
  return t == "drive_q" || t == "sense_q" || t == "drive_freq_hz" || t == "sense_freq_hz";
}

id::Identification run_static(const CsvTable& table, const std::string& target) {
  if (!table.has("temp_c")) {
    throw InputError(table.path() + ": target " + target + " needs a 'temp_c' column");
  }
  const std::vector<double> temp = table.numbers("temp_c");
  const std::vector<double> value = table.numbers(target);
  const bool quality = target == "drive_q" || target == "sense_q";
  try {
    return id::identify_static(temp, value,
                               quality ? id::StaticQuantity::quality_factor : id::StaticQuantity::frequency_hz,
                               target);
  } catch (const std::invalid_argument& e) {
    throw InputError(table.path() + ": " + e.what());
  }
}

id::Identification run_series(const CsvTable& table, const std::string& target, const IdentifyOptions& o) {
  table.require_increasing("time_s");
  id::SeriesRecord record;
  record.time_s = table.numbers("time_s");
  record.ambient_c = table.numbers("ambient_c");
  record.sensor_c = table.numbers("sensor_c");
  const bool gyro = target == "gyro_mv";
  if (gyro) record.gyro_mv = table.numbers("gyro_mv");
  if (!gyro || table.has("tec_a")) record.tec_a = table.numbers("tec_a");
  id::SeriesOptions options;
  const model::PlantParams plant = o.plant.empty() ? model::PlantParams{} : load_plant(o.plant);
  // A board's record cannot tell the casing's thermal resistance from the
  // TEC's resistance: it comes from the user (--r-th) or their plant, never
  // from the simulator's defaults.
  if (o.r_th_k_per_w > 0.0) {
    options.casing_r_th_k_per_w = o.r_th_k_per_w;
  } else if (!o.plant.empty()) {
    options.casing_r_th_k_per_w = 1.0 / plant.casing_ambient_w_per_k();
  }
  // With a base plant, the die lags the sensed casing as in that plant;
  // without one, the sensor temperature is taken as the gyro's.
  if (!o.plant.empty()) options.base_die_tau_s = plant.die_tau_s();
  Progress progress("identify");
  try {
    auto result = id::identify_series(record, gyro ? id::SeriesTarget::gyro_mv : id::SeriesTarget::sensor_c,
                                      options, {}, [&](double f) { progress.update(f); });
    progress.finish();
    return result;
  } catch (const std::invalid_argument& e) {
    throw InputError(table.path() + ": " + e.what());
  }
}

nlohmann::json to_json(const id::Identification& r, double elapsed_s) {
  using nlohmann::json;
  json j;
  j["target"] = r.target;
  json base_params = json::object();
  for (const auto& p : r.baseline_params) base_params[p.name] = p.value;
  j["baseline"] = {{"rms", r.baseline_rms},
                   {"max_abs", r.baseline_max_abs},
                   {"units", r.units},
                   {"whiteness_p", r.whiteness_p_before},
                   {"params", base_params}};
  j["regions"] = json::array();
  for (const auto& g : r.regions) {
    j["regions"].push_back({{"name", g.name},
                            {"start", g.start},
                            {"end", g.end},
                            {"x", r.x_name},
                            {"samples", g.samples},
                            {"rms", g.rms},
                            {"mean", g.mean}});
  }
  j["correlations"] = json::object();
  for (const auto& c : r.correlations) j["correlations"][c.signal] = c.r;
  j["added"] = json::array();
  for (const auto& a : r.added) {
    json params = json::object();
    json stderrs = json::object();
    for (const auto& p : a.params) {
      params[p.name] = p.value;
      stderrs[p.name] = p.std_error;
    }
    j["added"].push_back({{"effect", a.effect},
                          {"params", params},
                          {"stderr", stderrs},
                          {"delta_bic", a.delta_bic},
                          {"rms_after", a.rms_after},
                          {"fold_rms_before", a.fold_rms_before},
                          {"fold_rms_after", a.fold_rms_after}});
  }
  j["tried"] = json::array();
  for (const auto& t : r.tried) {
    json where = json::object();
    for (const auto& p : t.params) where[p.name] = p.value;
    j["tried"].push_back({{"round", t.round},
                          {"effect", t.effect},
                          {"delta_bic", t.delta_bic},
                          {"p_value", t.p_value},
                          {"long_run_factor", t.long_run_factor},
                          {"cv_gain", t.cv_gain},
                          {"heldout_z", t.heldout_z},
                          {"folds_improved", t.folds_improved},
                          {"t_ratio", t.t_ratio},
                          {"in_bounds", t.in_bounds},
                          {"passed", t.passed},
                          {"reason", t.reason},
                          {"params", where}});
  }
  j["verdict"] = r.verdict;
  j["statement"] = r.statement;
  j["unexplained"] = r.unexplained;
  j["noise_warnings"] = r.noise_warnings;
  j["alternatives"] = json::array();
  for (const auto& a : r.alternatives) {
    j["alternatives"].push_back({{"effect", a.effect},
                                 {"other", a.other},
                                 {"correlation", a.correlation},
                                 {"told_apart", a.told_apart},
                                 {"experiment", a.experiment}});
  }
  if (!r.note.empty()) j["note"] = r.note;
  j["final"] = {{"rms", r.final_rms}, {"max_abs", r.final_max_abs}, {"whiteness_p", r.whiteness_p_after}};
  j["shrink"] = r.shrink;
  j["elapsed_s"] = elapsed_s;
  return j;
}

std::string summary(const id::Identification& r, double elapsed_s) {
  std::ostringstream s;
  char line[256];
  s << "target " << r.target << ": baseline rms " << r.baseline_rms << " " << r.units << " (max "
    << r.baseline_max_abs << "), whiteness p " << r.whiteness_p_before << "\n";
  for (const auto& p : r.baseline_params) s << "  baseline " << p.name << " = " << p.value << "\n";
  s << "worst regions:\n";
  for (const auto& g : r.regions) {
    std::snprintf(line, sizeof line, "  %-34s rms %.4g  mean %+.4g  (%zu samples)\n", g.name.c_str(), g.rms,
                  g.mean, g.samples);
    s << line;
  }
  if (!r.correlations.empty()) {
    s << "residual correlation with:";
    for (const auto& c : r.correlations) {
      std::snprintf(line, sizeof line, " %s %+.2f;", c.signal.c_str(), c.r);
      s << line;
    }
    s << "\n";
  }
  for (const auto& a : r.added) {
    s << "added " << a.effect << ":";
    for (const auto& p : a.params) s << " " << p.name << " = " << p.value << " +/- " << p.std_error;
    std::snprintf(line, sizeof line, "  (delta BIC %.1f, rms after %.4g)\n", a.delta_bic, a.rms_after);
    s << line;
  }
  for (const auto& a : r.alternatives) s << "alternative: " << id::alternative_line(a) << "\n";
  for (const auto& w : r.noise_warnings) s << "warning: " << w << "\n";
  if (!r.note.empty()) s << "note: " << r.note << "\n";
  s << "verdict: " << r.verdict << " (" << r.statement << ")\n";
  std::snprintf(line, sizeof line, "final rms %.4g %s (max %.4g), whiteness p %.3g, shrink %.2fx, %.2f s\n",
                r.final_rms, r.units.c_str(), r.final_max_abs, r.whiteness_p_after, r.shrink, elapsed_s);
  s << line;
  return s.str();
}

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw RuntimeFailure("cannot write " + path.string());
}

// A column name in words for an axis: "time_s" -> "time (s)".
std::string axis_words(const std::string& column) {
  if (column == "time_s") return "time (s)";
  if (column == "temp_c") return "temperature (°C)";
  return column;
}

// Measured (wide, light) under the baseline and final models, and both
// residuals, on a shared x axis. The plot writer keeps each pixel column's
// extremes, so a 24 h 1 Hz record draws whole in a small file.
plot::Figure identification_figure(const id::Identification& r) {
  const auto series = [](std::string label, std::string color, bool dashed = false) {
    plot::Series s;
    s.label = std::move(label);
    s.color = std::move(color);
    s.dashed = dashed;
    return s;
  };
  plot::Series measured = series("measured", "#bbbbbb");
  measured.width_px = 4.0;
  plot::Series baseline = series("baseline model", "#d62728", true);
  plot::Series final_model = series("final model", "#1f77b4");
  plot::Series baseline_residual = series("baseline residual", "#d62728");
  plot::Series final_residual = series("final residual", "#1f77b4");
  for (std::size_t i = 0; i < r.x.size(); ++i) {
    for (plot::Series* s : {&measured, &baseline, &final_model, &baseline_residual, &final_residual}) {
      s->x.push_back(r.x[i]);
    }
    measured.y.push_back(r.measured[i]);
    baseline.y.push_back(r.baseline_model[i]);
    final_model.y.push_back(r.final_model[i]);
    baseline_residual.y.push_back(r.measured[i] - r.baseline_model[i]);
    final_residual.y.push_back(r.measured[i] - r.final_model[i]);
  }
  char title[256];
  std::snprintf(title, sizeof title, "gyrotc identify: %s, verdict %s; residual RMS %.3g -> %.3g %s (%.1fx smaller)",
                r.target.c_str(), r.verdict.c_str(), r.baseline_rms, r.final_rms, r.units.c_str(), r.shrink);
  plot::Figure f;
  f.title = title;
  f.x.title = axis_words(r.x_name);
  f.x.tight = r.x_name == "time_s";
  plot::Panel values;
  values.y.title = r.target + " (" + r.units + ")";
  values.series = {std::move(measured), std::move(baseline), std::move(final_model)};
  plot::Panel residuals;
  residuals.y.title = "residual (" + r.units + ")";
  residuals.series = {std::move(baseline_residual), std::move(final_residual)};
  f.panels = {std::move(values), std::move(residuals)};
  return f;
}

void write_report(const id::Identification& r, const IdentifyOptions& o, double elapsed_s) {
  namespace fs = std::filesystem;
  const fs::path dir(o.report_dir);

  // The curves, for any plotting tool.
  std::ostringstream csv;
  csv << r.x_name << ",measured,baseline_model,final_model,baseline_residual,final_residual,effect_signal\n";
  for (std::size_t i = 0; i < r.x.size(); ++i) {
    csv << r.x[i] << "," << r.measured[i] << "," << r.baseline_model[i] << "," << r.final_model[i] << ","
        << r.measured[i] - r.baseline_model[i] << "," << r.measured[i] - r.final_model[i] << ","
        << r.effect_signal[i] << "\n";
  }
  write_text(dir / "curves.csv", csv.str());
  plot::write_svg(identification_figure(r), (dir / "plot.svg").string());

  std::ostringstream md;
  md << "# gyrotc identify: " << r.target << "\n\n";
  md << "Data: `" << o.data << "`. Verdict: **" << r.verdict << "**: " << r.statement
     << ". Shrink of the RMS gap: **" << r.shrink << "x**.\n\n";
  md << "| | RMS (" << r.units << ") | max abs | Ljung-Box whiteness p |\n|---|---|---|---|\n";
  md << "| baseline | " << r.baseline_rms << " | " << r.baseline_max_abs << " | " << r.whiteness_p_before << " |\n";
  md << "| final | " << r.final_rms << " | " << r.final_max_abs << " | " << r.whiteness_p_after << " |\n\n";
  if (!r.baseline_params.empty()) {
    // On time series the noise parameters listed are the final model's.
    md << (r.x_name == "time_s" ? "Calibrated baseline (its noise: the final model's):" : "Calibrated baseline:");
    for (const auto& p : r.baseline_params) md << " " << p.name << " = " << p.value << ";";
    md << "\n\n";
  }
  md << "## Where the baseline disagrees (worst first)\n\n| region | samples | RMS | mean |\n|---|---|---|---|\n";
  for (const auto& g : r.regions) {
    md << "| " << g.name << " | " << g.samples << " | " << g.rms << " | " << g.mean << " |\n";
  }
  if (!r.correlations.empty()) {
    md << "\nCorrelation of the baseline residual with candidate signals:";
    for (const auto& c : r.correlations) md << " " << c.signal << " " << c.r << ";";
    md << "\n";
  }
  md << "\n## Effects added\n\n";
  if (r.added.empty()) md << "None passed every test.\n";
  for (const auto& a : r.added) {
    md << "### " << a.effect << "\n\n| parameter | value | standard error |\n|---|---|---|\n";
    for (const auto& p : a.params) md << "| " << p.name << " | " << p.value << " | " << p.std_error << " |\n";
    md << "\ndelta BIC " << a.delta_bic << ", RMS after " << a.rms_after << " " << r.units
       << ".\n\nHeld-out RMS per fold, before -> after (time series: of the one-step prediction errors under the noise model):";
    for (std::size_t f = 0; f < a.fold_rms_before.size(); ++f) {
      md << " " << a.fold_rms_before[f] << " -> " << a.fold_rms_after[f] << ";";
    }
    md << "\n\n";
  }
  if (!r.alternatives.empty()) {
    md << "## Alternatives\n\nEffects whose fitted contributions are alike over this record, and the experiment "
          "that would tell them apart:\n\n";
    for (const auto& a : r.alternatives) {
      md << "- " << id::alternative_line(a);
      if (a.told_apart && !a.experiment.empty()) md << " (to confirm: " << a.experiment << ")";
      md << ".\n";
    }
    md << "\n";
  }
  for (const auto& w : r.noise_warnings) md << "Warning: " << w << ".\n\n";
  if (!r.note.empty()) md << "Note: " << r.note << "\n\n";
  md << "## Every candidate tried\n\nRound 0: the generic probes, tried after the library; one that passes means "
        "structure remains that no library effect explains.\n\n| round | effect | p-value | delta BIC | CV gain | "
        "CV fall z | folds improved | t ratio | in bounds | kept / why not |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& t : r.tried) {
    md << "| " << t.round << " | " << t.effect << " | " << t.p_value << " | " << t.delta_bic << " | " << t.cv_gain << " | "
       << t.heldout_z << " | " << t.folds_improved << " | " << t.t_ratio << " | " << (t.in_bounds ? "yes" : "no") << " | "
       << (t.passed ? "passed" : t.reason) << " |\n";
  }
  md << "\n![measured against the baseline and final models, and the residuals](plot.svg)\n\n";
  md << "The curves (measured, baseline and final model, residuals, the effect's signal `"
     << r.effect_signal_name << "`) are in `curves.csv`.\n\n";
  md << "Run time " << elapsed_s << " s.\n";
  write_text(dir / "report.md", md.str());
}

// The base plant (--plant, else the documented defaults) with the effects
// found switched on, in the simulator's plant format.
void write_plant(const id::Identification& r, const IdentifyOptions& o) {
  model::PlantParams params = o.plant.empty() ? model::PlantParams{} : load_plant(o.plant);
  const auto value = [](const id::AddedEffect& a, const std::string& name) {
    for (const auto& p : a.params) {
      if (p.name == name) return p.value;
    }
    throw RuntimeFailure("effect " + a.effect + " has no parameter " + name);
  };
  for (const auto& a : r.added) {
    if (a.effect == "thermal_lag") {
      params.effects.thermal_lag = model::ThermalLagEffect{value(a, "tau_s")};
    } else if (a.effect == "rate_sensitivity") {
      params.effects.rate_sensitivity = model::RateSensitivityEffect{value(a, "k_mv_per_c_per_s")};
    } else if (a.effect == "ramp_hysteresis") {
      params.effects.ramp_hysteresis = model::RampHysteresisEffect{value(a, "h_mv"), value(a, "r0_c_per_s")};
    } else if (a.effect == "warm_up") {
      params.effects.warm_up = model::WarmUpEffect{value(a, "a_mv"), value(a, "tau_s")};
    } else if (a.effect == "linear_drift") {
      params.effects.linear_drift = model::LinearDriftEffect{value(a, "d_mv_per_h")};
    } else if (a.effect == "ambient_sensitivity") {
      params.effects.ambient_sensitivity = model::AmbientSensitivityEffect{value(a, "k_mv_per_c"), value(a, "ref_c")};
    } else if (a.effect == "tec_joule_heating") {
      // Without r_ohm (no --r-th, no --plant) the measured rise per A^2 is kept
      // through the base plant's own thermal resistance.
      const bool has_r_ohm = std::any_of(a.params.begin(), a.params.end(),
                                         [](const id::EffectParam& p) { return p.name == "r_ohm"; });
      const double r_ohm = has_r_ohm ? value(a, "r_ohm")
                                     : 2.0 * value(a, "rise_k_per_a2") * params.casing_ambient_w_per_k();
      params.effects.tec_joule_heating = model::TecJouleHeatingEffect{r_ohm};
    }
  }
  save_plant(params, o.out_plant);
}

void run_identify(const IdentifyOptions& o) {
  const CsvTable table = CsvTable::read(o.data);
  const bool series = table.has("time_s");
  std::string target = o.target;
  if (target.empty()) {
    if (!series) {
      throw InputError(o.data + ": no time_s column; a static table needs --target "
                                "drive_q|sense_q|drive_freq_hz|sense_freq_hz");
    }
    target = "gyro_mv";
  }
  if (is_static_target(target) && !o.out_plant.empty()) {
    throw InputError("--out-plant applies to the time-series targets gyro_mv and sensor_c");
  }
  if (!is_static_target(target) && !series) {
    throw InputError(o.data + ": target " + target + " needs a time series (no time_s column)");
  }
  if (!o.report_dir.empty()) prepare_output_dir(o.report_dir, "--report");
  if (!o.out_plant.empty()) prepare_output_file(o.out_plant, "--out-plant");
  const auto start = std::chrono::steady_clock::now();
  const id::Identification result = is_static_target(target) ? run_static(table, target)
                                                              : run_series(table, target, o);
  const double elapsed_s = seconds_since(start);
  if (o.json) {
    std::printf("%s\n", to_json(result, elapsed_s).dump(2).c_str());
  } else {
    std::printf("%s", summary(result, elapsed_s).c_str());
  }
  if (!o.report_dir.empty()) write_report(result, o, elapsed_s);
  if (!o.out_plant.empty()) write_plant(result, o);
}

}  // namespace

void add_identify_command(CLI::App& app) {
  auto options = std::make_shared<IdentifyOptions>();
  CLI::App* cmd = app.add_subcommand(
      "identify",
      "Find the physical effect the model lacks: calibrate the base model (and, on time series, its noise: "
      "white plus a slow bias wander) to a record, localise the gap, try each named effect (a nested-model "
      "test whose p-value scales with the record, blocked cross-validation, confidence intervals, physical "
      "bounds), report what the record is consistent with and how much the gap shrinks. Time series may be "
      "irregularly sampled; gaps are bridged or the record refused with the reason.");
  cmd->add_option("--data", options->data,
                  "CSV record: time series (time_s, ambient_c, sensor_c, gyro_mv[, tec_a]) or a static "
                  "table (temp_c with drive_q, sense_q, drive_freq_hz, sense_freq_hz)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--target", options->target,
                  "what to explain: gyro_mv (default for time series), sensor_c, drive_q, sense_q, "
                  "drive_freq_hz, sense_freq_hz")
      ->check(CLI::IsMember({"gyro_mv", "sensor_c", "drive_q", "sense_q", "drive_freq_hz", "sense_freq_hz"}));
  cmd->add_option("--plant", options->plant,
                  "base plant description (TOML, `gyrotc simulate --plant` format); --out-plant writes it "
                  "back with the effects found switched on")
      ->check(CLI::ExistingFile);
  cmd->add_option("--report", options->report_dir,
                  "write report.md, curves.csv and plot.svg (measured vs baseline and final model, residuals) "
                  "into this directory");
  cmd->add_option("--out-plant", options->out_plant,
                  "write the plant description (the base plant with the effects found switched on, as "
                  "[effects.<name>] tables) for `gyrotc simulate --plant`");
  cmd->add_option("--r-th", options->r_th_k_per_w,
                  "casing-to-ambient thermal resistance, K/W, for the sensor_c target (converts the fitted "
                  "Joule term, the casing's rise per A^2, to r_ohm); default: that of --plant; without "
                  "either only rise_k_per_a2 is reported (a record cannot tell the two apart)")
      ->check(positive_number());
  cmd->add_flag("--json", options->json, "print the result as one JSON object");
  cmd->callback([options] { run_identify(*options); });
}

}  // namespace gyrotc::app
