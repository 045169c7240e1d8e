// `gyrotc simulate`: the closed-loop chamber simulation (issue 4). Runs the
// real Controller on the simulated board in lockstep over a chamber profile
// and prints the summary; optionally writes the 1 Hz time series (CSV) and a
// plot.

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/calibrate/sweep_experiment.hpp"
#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/app/formats/calibration_file.hpp"
#include "gyrotc/app/formats/chamber_profile_file.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/data_dir.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc/app/support/progress.hpp"
#include "gyrotc/app/support/stopwatch.hpp"
#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc/app/support/output_path.hpp"
#include "gyrotc/app/workflows/tuning.hpp"

namespace gyrotc::app {
namespace {

struct SimulateOptions {
  std::string profile = "fig26";
  double ambient_c = 16.0;  // --profile tune: the room's temperature
  double ambient_step_c = 0.0;  // --profile tune: the chamber's step (tune_experiment_room)
  double experiment_scale = 1.0;  // --profile tune: tune::ExperimentPlan::scaled
  std::string controller = "paper";
  std::string plant;
  std::string calibration;
  double sample_rate_hz = 1000.0;
  std::uint64_t seed = 1;
  std::string adc_model = "transaction";
  std::string out;
  std::string plot;
  std::string compare;  // another run's --out folder, overlaid on the plot
  std::string rate_csv;
  std::string rate_window;  // "START:END", seconds from the profile's start
  bool json = false;
};

struct Window {
  double start_s = 0.0;
  double end_s = 0.0;
};

Window parse_window(const std::string& text) {
  const auto colon = text.find(':');
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no colon");
    std::size_t used = 0;
    Window w;
    const std::string a = text.substr(0, colon);
    const std::string b = text.substr(colon + 1);
    w.start_s = std::stod(a, &used);
    if (used != a.size()) throw std::invalid_argument("trailing text");
    w.end_s = std::stod(b, &used);
    if (used != b.size()) throw std::invalid_argument("trailing text");
    if (!(w.end_s > w.start_s) || w.start_s < 0.0) throw std::invalid_argument("empty window");
    return w;
  } catch (const std::exception&) {
    throw InputError("--rate-window '" + text + "': expected START:END in seconds from the profile's start, START < END");
  }
}

// Writes the compensated rate of every ADC sample inside the window: the
// full-rate record `gyrotc allan` reads (time_s, rate_dps). Samples the
// controller marks invalid are left out and counted.
class RateWriter {
 public:
  RateWriter(const std::string& path, double from_s, double to_s) : path_(path), from_s_(from_s), to_s_(to_s) {
    file_ = std::fopen(path.c_str(), "w");
    if (file_ == nullptr) throw RuntimeFailure(path + ": cannot write the rate record");
    std::fprintf(file_, "time_s,rate_dps\n");
  }
  ~RateWriter() {
    if (file_ != nullptr) std::fclose(file_);
  }
  RateWriter(const RateWriter&) = delete;
  RateWriter& operator=(const RateWriter&) = delete;

  void add(double now_s, const SampleResult& r) {
    if (now_s < from_s_ || now_s > to_s_) return;
    if (!r.valid) {
      ++invalid_;
      return;
    }
    std::fprintf(file_, "%.6f,%.9g\n", now_s, r.rate_dps);
    ++written_;
  }
  void close() {
    const bool ok = std::ferror(file_) == 0;
    const int rc = std::fclose(file_);
    file_ = nullptr;
    if (rc != 0 || !ok) throw RuntimeFailure(path_ + ": cannot write the rate record");
  }
  std::uint64_t written() const { return written_; }
  std::uint64_t invalid() const { return invalid_; }

 private:
  std::string path_;
  double from_s_;
  double to_s_;
  std::FILE* file_ = nullptr;
  std::uint64_t written_ = 0;
  std::uint64_t invalid_ = 0;
};

// Another run's 1 Hz series (its --out folder's simulation.csv), for
// --compare: read before this run starts, so a wrong folder costs nothing.
struct ComparedRun {
  std::string label;
  std::vector<double> time_s, casing_c, error_c, tec_a, rate_dps;
};

ComparedRun read_compared_run(const std::string& dir) {
  const std::string path = dir + "/simulation.csv";
  if (!std::filesystem::is_regular_file(path)) {
    throw InputError("--compare " + dir + ": no simulation.csv there (the --out folder of another simulate run)");
  }
  const CsvTable t = CsvTable::read(path);
  ComparedRun r;
  r.label = std::filesystem::path(dir).lexically_normal().filename().string();
  if (r.label.empty() || r.label == ".") r.label = dir;
  r.time_s = t.numbers("time_s");
  r.casing_c = t.numbers("casing_c");
  const std::vector<double> setpoint = t.numbers("setpoint_c");
  r.tec_a = t.numbers("tec_a");
  r.rate_dps = t.numbers_or_nan("rate_dps_compensated");
  for (std::size_t i = 0; i < r.time_s.size(); ++i) r.error_c.push_back(r.casing_c[i] - setpoint[i]);
  return r;
}

// The times after settling (+ the settle hold) when the ambient was in the
// band the casing error is judged on (RunSummary::max_abs_error_c_in_band).
std::vector<plot::Band> judged_spans(const SimulationResult& r) {
  std::vector<plot::Band> spans;
  if (r.summary.settle_s < 0.0) return spans;
  const double from_s = r.summary.settle_s + 300.0;
  bool open = false;
  for (const auto& row : r.rows) {
    const bool in = row.time_s >= from_s && row.ambient_c >= -20.0 && row.ambient_c <= 35.0;
    if (in && !open) spans.push_back({"", row.time_s, row.time_s, "#1f77b4", true});
    if (in) spans.back().to = row.time_s;
    open = in;
  }
  if (!spans.empty()) spans.front().label = "judged: ambient -20..35 °C";
  return spans;
}

// Stacked panels on one time axis (seed Fig. 26 as an engineer reads it):
// temperatures; the casing's error with the +/-0.3 C band; the TEC current on
// the stage's full range; the bias before compensation; the rate after it.
plot::Figure simulation_figure(const SimulationResult& r, const SimulateOptions& o, double scale_mv_per_dps,
                               const model::ChamberProfile& profile, double tec_limit_a, bool regulated,
                               const std::optional<ComparedRun>& other) {
  plot::Figure f;
  f.title = "gyrotc simulate: " + o.profile + " profile, " +
            (o.profile == "tune"      ? std::string("identification experiment")
             : o.profile == "selfcal" ? std::string("self-calibration sweep")
                                      : o.controller + " controller");
  f.x.title = "time (s)";
  f.x.tight = true;
  f.panel_height_px = 150.0;
  f.width_px = 1000.0;
  plot::Series casing{"casing", {}, {}, "#d62728"}, setpoint{"setpoint", {}, {}, "#555555", true},
      ambient{"chamber (ambient)", {}, {}, "#1f77b4"}, error{"casing - setpoint", {}, {}, "#d62728"},
      current{"TEC current", {}, {}, "#ff7f0e"}, uncompensated{"bias, uncompensated", {}, {}, "#9467bd"},
      compensated{"rate, compensated", {}, {}, "#2ca02c"};
  for (const auto& row : r.rows) {
    for (auto* s : {&casing, &setpoint, &ambient, &error, &current, &uncompensated, &compensated}) {
      s->x.push_back(row.time_s);
    }
    casing.y.push_back(row.casing_c);
    setpoint.y.push_back(row.setpoint_c);
    ambient.y.push_back(row.ambient_c);
    error.y.push_back(row.casing_c - row.setpoint_c);
    current.y.push_back(row.tec_a);
    uncompensated.y.push_back(row.gyro_mv / scale_mv_per_dps);
    compensated.y.push_back(row.rate_dps_compensated);
  }
  plot::Panel temps, err, tec, bias, rate;
  temps.y.title = "temperature (°C)";
  temps.series = {ambient, casing};
  if (regulated) temps.series.push_back(setpoint);
  err.y.title = "error (°C)";
  err.y.min = -1.0;
  err.y.max = 1.0;
  err.series = {error};
  err.bands = {{"±0.3 °C band", -0.3, 0.3, "#2ca02c", false}};
  if (regulated) {
    for (const auto& span : judged_spans(r)) err.bands.push_back(span);
  }
  tec.y.title = "TEC (A)";
  tec.y.min = -tec_limit_a;
  tec.y.max = tec_limit_a;
  tec.series = {current};
  bias.y.title = "bias (°/s)";
  bias.series = {uncompensated};
  rate.y.title = "rate (°/s)";
  rate.series = {compensated};
  if (other) {
    const std::string tag = "vs " + other->label;
    // A thin black line over this run's coloured one (dashes break up on
    // 1 Hz data; under it, a calm run hides beneath a chattering one).
    auto over = [](plot::Panel& p, plot::Series s) {
      s.width_px = 0.9;
      p.series.push_back(std::move(s));
    };
    over(temps, {"casing, " + tag, other->time_s, other->casing_c, "#000000"});
    over(err, {"error, " + tag, other->time_s, other->error_c, "#000000"});
    over(tec, {"TEC, " + tag, other->time_s, other->tec_a, "#000000"});
    over(rate, {"rate, " + tag, other->time_s, other->rate_dps, "#000000"});
  }
  f.panels = regulated ? std::vector<plot::Panel>{temps, err, tec, bias, rate}
                       : std::vector<plot::Panel>{temps, tec, bias, rate};
  // Segment letters where they are letters (seed Fig. 26's A..P), not a
  // 49-segment chamber programme whose names would overprint each other.
  bool short_names = profile.segments().size() <= 30;
  for (const auto& seg : profile.segments()) short_names = short_names && seg.name.size() <= 2;
  if (short_names) {
    for (const auto& seg : profile.segments()) {
      if (seg.end_s > seg.start_s) f.segments.push_back({seg.name, seg.start_s, seg.end_s});
    }
  }
  return f;
}

std::string default_calibration_path() { return data_dir() + "/calibration_table2.toml"; }

nlohmann::json summary_json(const SimulateOptions& o, const std::string& calibration_name,
                            const SimulationResult& r, double wall_s) {
  nlohmann::json j;
  const auto& s = r.summary;
  j["profile"] = o.profile;
  j["controller"] = o.profile == "tune"      ? std::string("identification experiment")
                    : o.profile == "selfcal" ? std::string("self-calibration sweep")
                                             : o.controller;
  j["calibration"] = calibration_name;
  j["sample_rate_hz"] = o.sample_rate_hz;
  j["seed"] = o.seed;
  j["simulated_s"] = s.simulated_s;
  j["wall_s"] = wall_s;
  j["speedup"] = wall_s > 0.0 ? s.simulated_s / wall_s : 0.0;
  j["samples"] = r.counters.samples;
  // Control figures only where something held the setpoint: with the
  // controller off, or during an experiment, a "settle time" or an error from
  // the setpoint means nothing.
  const bool regulated = o.controller != "off" && o.profile != "tune" && o.profile != "selfcal";
  if (regulated) {
    j["settle_s"] = s.settle_s >= 0.0 ? nlohmann::json(s.settle_s) : nlohmann::json(nullptr);
    // null when it never settled: there is no in-band hold to judge, not a zero error.
    j["max_abs_error_c_in_band"] =
        s.settle_s >= 0.0 ? nlohmann::json(s.max_abs_error_c_in_band) : nlohmann::json(nullptr);
  }
  j["bias_uncompensated_max_abs_dps"] = s.bias_uncompensated_max_abs_dps;
  j["bias_compensated_max_abs_dps"] = s.bias_compensated_max_abs_dps;
  j["calibration_error_max_abs_dps"] = s.calibration_error_max_abs_dps;
  nlohmann::json segments = nlohmann::json::array();
  for (const auto& seg : s.segments) {
    nlohmann::json row;
    row["segment"] = seg.segment;
    row["ambient_c"] = seg.ambient_start_c == seg.ambient_end_c
                           ? nlohmann::json(seg.ambient_end_c)
                           : nlohmann::json::array({seg.ambient_start_c, seg.ambient_end_c});
    if (regulated) row["max_abs_error_c"] = seg.max_abs_error_c;
    row["tec_saturated"] = seg.tec_saturated;
    if (seg.has_bias) {
      row["bias_uncompensated_dps"] = seg.bias_uncompensated_dps;
      row["bias_compensated_dps"] = seg.bias_compensated_dps;
      row["calibration_error_dps"] = seg.calibration_error_dps;
    }
    segments.push_back(row);
  }
  j["segments"] = segments;
  return j;
}

void print_text(const nlohmann::json& j, const std::optional<std::string>& csv,
                const std::optional<std::string>& plot) {
  auto num = [](const nlohmann::json& v, const char* fmt) {
    if (v.is_null()) return std::string("never");
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v.get<double>());
    return std::string(buf);
  };
  std::string die;
  if (j.value("calibration_die_lag_s", 0.0) > 0.0) {
    die = " (of the die, " + num(j["calibration_die_lag_s"], "%.1f") + " s behind the sensor)";
  }
  std::printf("gyrotc simulate: profile %s, controller %s, calibration %s%s\n",
              j["profile"].get<std::string>().c_str(), j["controller"].get<std::string>().c_str(),
              j["calibration"].get<std::string>().c_str(), die.c_str());
  std::printf("  simulated %s s in %s s wall (speedup %s x, %s Hz sampling)\n",
              num(j["simulated_s"], "%.0f").c_str(), num(j["wall_s"], "%.3f").c_str(),
              num(j["speedup"], "%.0f").c_str(), num(j["sample_rate_hz"], "%g").c_str());
  if (j.contains("settle_s")) {
    std::printf("  settle_s                        %s\n", num(j["settle_s"], "%.0f").c_str());
    if (j["max_abs_error_c_in_band"].is_null()) {
      std::printf("  max_abs_error_c_in_band         n/a (never settled)\n");
    } else {
      std::printf("  max_abs_error_c_in_band         %s C  (ambient -20..35 C, from settle_s + 300 s on)\n",
                  num(j["max_abs_error_c_in_band"], "%.3f").c_str());
    }
  } else {
    std::printf("  no setpoint held (%s): no settling time or control error\n",
                j["controller"].get<std::string>().c_str());
  }
  std::printf("  bias_uncompensated_max_abs_dps  %s\n",
              num(j["bias_uncompensated_max_abs_dps"], "%.3f").c_str());
  std::printf("  bias_compensated_max_abs_dps    %s\n",
              num(j["bias_compensated_max_abs_dps"], "%.3f").c_str());
  std::printf("  calibration_error_max_abs_dps   %s  (the same without the gyro's noise and effects)\n",
              num(j["calibration_error_max_abs_dps"], "%.4f").c_str());
  std::printf("  %-14s %-14s %16s %14s %14s %14s %14s\n", "segment", "ambient_c", "max_abs_error_c",
              "tec_saturated", "bias_unc_dps", "bias_comp_dps", "cal_error_dps");
  for (const auto& seg : j["segments"]) {
    std::string ambient = seg["ambient_c"].is_array()
                              ? num(seg["ambient_c"][0], "%.0f") + ".." + num(seg["ambient_c"][1], "%.0f")
                              : num(seg["ambient_c"], "%.0f");
    std::printf("  %-14s %-14s %16s %14s %14s %14s %14s\n", seg["segment"].get<std::string>().c_str(),
                ambient.c_str(),
                seg.contains("max_abs_error_c") ? num(seg["max_abs_error_c"], "%.3f").c_str() : "-",
                seg["tec_saturated"].get<bool>() ? "yes" : "no",
                seg.contains("bias_uncompensated_dps") ? num(seg["bias_uncompensated_dps"], "%.3f").c_str() : "-",
                seg.contains("bias_compensated_dps") ? num(seg["bias_compensated_dps"], "%.3f").c_str() : "-",
                seg.contains("calibration_error_dps") ? num(seg["calibration_error_dps"], "%.4f").c_str() : "-");
  }
  if (j.contains("record") && j["profile"] == "selfcal") {
    const auto& e = j["experiment"];
    const auto held = [&](const char* dwell, const char* settled) {
      if (!e[dwell].is_number()) return std::string("-");
      return num(e[dwell], "%.0f") + " s" + (e[settled].get<bool>() ? "" : " (the gyro still moving)");
    };
    std::printf("  self-calibration sweep: %.0f s at %.1f C ambient%s; casing %s .. %s C (asked %.1f .. %.1f C); "
                "ends held %s and %s\n"
                "  record for `gyrotc calibrate --data %s --out calibration.toml`\n",
                e["duration_s"].get<double>(), e["ambient_c"].get<double>(),
                e["finished"].get<bool>() ? "" : " (did not finish)", num(e["reached_low_c"], "%.1f").c_str(),
                num(e["reached_high_c"], "%.1f").c_str(), e["asked_low_c"].get<double>(),
                e["asked_high_c"].get<double>(), held("dwell_low_s", "settled_low").c_str(),
                held("dwell_high_s", "settled_high").c_str(), j["record"].get<std::string>().c_str());
  } else if (j.contains("record")) {
    const nlohmann::json& e = j["experiment"];
    const double step_c = e["ambient_step_c"].get<double>();
    const std::string chamber =
        step_c == 0.0 ? num(e["ambient_c"], "%.1f") + " C ambient"
                      : num(e["ambient_c"], "%.1f") + " C ambient, stepped to " +
                            num(nlohmann::json(e["ambient_c"].get<double>() + step_c), "%.1f") + " C from " +
                            num(e["ambient_step_at_s"], "%.0f") + " s";
    std::printf("  identification experiment: %.0f s at %s%s; record for `gyrotc tune`: %s\n",
                e["duration_s"].get<double>(), chamber.c_str(), e["finished"].get<bool>() ? "" : " (did not finish)",
                j["record"].get<std::string>().c_str());
  }
  if (csv) std::printf("  time series (1 Hz CSV): %s\n", csv->c_str());
  if (plot) std::printf("  plot: %s\n", plot->c_str());
}

// A preset by name, or a controller file (tune's output) on the plant's limits.
ControllerConfig controller_for(const std::string& name, const model::PlantParams& plant) {
  if (name == "paper" || name == "tuned" || name == "off" || name == "oracle") {
    return controller_preset(parse_controller_mode(name), plant);
  }
  if (!std::filesystem::is_regular_file(name)) {
    throw InputError("--controller '" + name + "': neither paper, tuned, off, oracle nor a controller file");
  }
  return apply_controller_file(load_controller_file(name), controller_preset(ControllerMode::paper, plant), name);
}

void run(const SimulateOptions& o) {
  if (!o.out.empty()) prepare_output_dir(o.out, "--out");
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  if (!o.rate_csv.empty()) prepare_output_file(o.rate_csv, "--rate-csv");
  if (!o.compare.empty() && o.plot.empty()) throw InputError("--compare: only with --plot (it overlays the plot)");
  std::optional<ComparedRun> compared;
  if (!o.compare.empty()) compared = read_compared_run(o.compare);
  const bool tune_experiment = o.profile == "tune";
  const bool selfcal = o.profile == "selfcal";
  const bool experiment = tune_experiment || selfcal;
  const tune::ExperimentPlan plan = tune::ExperimentPlan{}.scaled(o.experiment_scale);
  SimulationSetup setup;
  if (!o.plant.empty()) setup.plant = load_plant(o.plant);
  // The self-calibration starts from a unit that has sat in the room.
  if (selfcal) setup.plant.initial_temp_c = o.ambient_c;
  setup.controller = controller_for(experiment ? std::string("paper") : o.controller, setup.plant);
  const calibrate::SweepPlan sweep_plan = calibrate::plan_below_over_temp(setup.controller.limits.over_temp_c);
  const calibrate::SweepRange sweep_range = sweep_plan.range(o.ambient_c, setup.controller.setpoint_c);
  const model::ChamberProfile profile =
      tune_experiment ? tune_experiment_room(o.ambient_c, plan, o.ambient_step_c)
      : selfcal       ? model::ChamberProfile({{"selfcal", 0.0, 2.0 * sweep_plan.max_duration_s(sweep_range),
                                                o.ambient_c, o.ambient_c}})
                      : chamber_profile_by_name(o.profile, data_dir());
  setup.seed = o.seed;
  setup.sample_rate_hz = o.sample_rate_hz;
  setup.adc_model = o.adc_model == "bit" ? hal::SimAdcModel::bit_level : hal::SimAdcModel::transaction;
  tune::IdentificationExperiment program(plan);
  calibrate::SweepExperiment sweep(sweep_plan);
  if (tune_experiment) setup.program = &program;
  if (selfcal) setup.program = &sweep;
  // Refuse a bad output directory before a long run.
  if (!o.out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.out, ec);
    if (ec) throw RuntimeFailure(o.out + ": cannot create the output directory: " + ec.message());
  }

  std::string calibration_name;
  std::optional<fit::BiasModel> model;
  const std::string calibration_path = o.calibration.empty() ? default_calibration_path() : o.calibration;
  if (!o.calibration.empty() || std::filesystem::exists(calibration_path)) {
    const Calibration c = read_calibration(calibration_path);
    model.emplace(c.model);
    setup.scale_mv_per_dps = c.scale_mv_per_dps;
    setup.die_lag_s = c.die_lag_s;
    calibration_name = calibration_path;
  } else {
    model.emplace(fit::BiasModel::paper_reference());
    calibration_name = "paper_reference (built in; " + calibration_path + " not found)";
  }
  setup.calibration = &*model;

  std::optional<RateWriter> rate_writer;
  if (!o.rate_csv.empty()) {
    if (o.rate_window.empty()) throw InputError("--rate-csv needs --rate-window START:END");
    const Window w = parse_window(o.rate_window);
    rate_writer.emplace(o.rate_csv, profile.start_s() + w.start_s, profile.start_s() + w.end_s);
    setup.on_sample = [&rate_writer](double now_s, const SampleResult& r) { rate_writer->add(now_s, r); };
  }

  Progress progress("simulate");
  const auto start = std::chrono::steady_clock::now();
  SimulationResult result = run_simulation(setup, profile, [&](double f) { progress.update(f); });
  const double wall_s = seconds_since(start);
  progress.finish();

  std::optional<std::string> csv_path;
  std::optional<std::string> plot_path;
  if (!o.plot.empty()) {
    const bool regulated = o.controller != "off" && !experiment;
    plot::write_svg(simulation_figure(result, o, setup.scale_mv_per_dps, profile, setup.plant.current_limit_a,
                                      regulated, compared),
                    o.plot);
    plot_path = o.plot;
  }
  nlohmann::json j = summary_json(o, calibration_name, result, wall_s);
  j["calibration_die_lag_s"] = setup.die_lag_s;
  if (tune_experiment) {
    j["experiment"] = {{"ambient_c", o.ambient_c},
                       {"ambient_step_c", o.ambient_step_c},
                       {"ambient_step_at_s", ambient_step_at_s(plan)},
                       {"duration_s", result.rows.empty() ? 0.0 : result.rows.back().time_s},
                       {"finished", program.phase() == tune::ExperimentPhase::done},
                       {"wrong_way", program.phase() == tune::ExperimentPhase::wrong_way}};
  }
  if (selfcal) {
    auto temp = [](double c) { return std::isnan(c) ? nlohmann::json(nullptr) : nlohmann::json(c); };
    j["experiment"] = {{"ambient_c", o.ambient_c},
                       {"duration_s", result.rows.empty() ? 0.0 : result.rows.back().time_s},
                       {"finished", sweep.phase() == calibrate::SweepPhase::done},
                       {"asked_low_c", sweep_range.low_c},
                       {"asked_high_c", sweep_range.high_c},
                       {"reached_low_c", temp(sweep.reached_low_c())},
                       {"reached_high_c", temp(sweep.reached_high_c())},
                       {"dwell_low_s", temp(sweep.dwell_low_s())},
                       {"dwell_high_s", temp(sweep.dwell_high_s())},
                       {"settled_low", sweep.settled_low()},
                       {"settled_high", sweep.settled_high()}};
  }
  if (!o.out.empty()) {
    csv_path = o.out + "/simulation.csv";
    if (experiment) {
      write_board_record_csv(result.rows, o.out + "/record.csv");
      j["record"] = o.out + "/record.csv";
    }
    write_records_csv(result.rows, *csv_path);
    std::ofstream summary(o.out + "/summary.json");
    summary << j.dump(2) << "\n";
    if (!summary) throw RuntimeFailure(o.out + "/summary.json: cannot write");
    j["csv"] = *csv_path;
  }
  if (plot_path) j["plot"] = *plot_path;
  if (rate_writer) {
    rate_writer->close();
    j["rate_csv"] = o.rate_csv;
    j["rate_samples"] = rate_writer->written();
    j["rate_invalid_samples"] = rate_writer->invalid();
  }
  if (o.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    print_text(j, csv_path, plot_path);
    if (rate_writer) {
      std::printf("  full-rate compensated rate: %s (%llu samples, %llu invalid left out)\n", o.rate_csv.c_str(),
                  static_cast<unsigned long long>(rate_writer->written()),
                  static_cast<unsigned long long>(rate_writer->invalid()));
    }
  }
  if (tune_experiment && program.phase() == tune::ExperimentPhase::wrong_way) {
    throw RuntimeFailure(tune::wrong_way_message(program.plan()));
  }
}

}  // namespace

void add_simulate_command(CLI::App& app) {
  auto options = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Closed-loop chamber simulation: the real controller on the simulated board (plant model,\n"
      "ADS1251/AD5060/DS18B20/OPA548 simulators) in virtual time, much faster than real time.");
  cmd->add_option("--profile", options->profile,
                  "chamber profile: fig26 (seed Section 6.2), table2 (-40..80 C in 5 C steps, 60 min "
                  "soaks, seed Section 4.2), a CSV file (time_s,ambient_c or the fig26 segment format), "
                  "selfcal: the self-calibration sweep of `gyrotc calibrate` (the TEC sweeps the casing from 12 C "
                  "below --ambient-c to 12 C above the setpoint and back, at most 4 h at 20 C; writes record.csv "
                  "into --out), or "
                  "tune: the identification experiment of `gyrotc tune` (<= 3 h at --ambient-c; writes "
                  "record.csv, the board's record, into --out)")
      ->capture_default_str();
  cmd->add_option("--ambient-c", options->ambient_c,
                  "--profile tune and selfcal: the room's (chamber's) constant temperature")
      ->check(CLI::Range(-40.0, 80.0))
      ->capture_default_str();
  cmd->add_option("--ambient-step-c", options->ambient_step_c,
                  "--profile tune: the chamber steps the ambient by this much (at 1 C/min) once the unit is held "
                  "near the setpoint, so that tune sees how the room reaches the casing sensor; 0: the room "
                  "holds still (a bench without a chamber)")
      ->check(CLI::Range(-40.0, 40.0))
      ->capture_default_str();
  cmd->add_option("--experiment-scale", options->experiment_scale,
                  "--profile tune on a plant faster than the reference: every phase's length times this factor "
                  "(0 < F <= 1), as gyrotc record --experiment-scale")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  cmd->add_option("--controller", options->controller,
                  "paper: the seed's integral-separated PID; tuned: ours (retuned gains, feed-forward "
                  "from the ambient sensor); off: TEC off, compensation only; oracle: the model-based loop "
                  "designed on the plant's own physics (the reference: what a loop that knows the plant "
                  "holds); or a controller file (TOML) as `gyrotc tune` writes it")
      ->capture_default_str();
  cmd->add_option("--plant", options->plant, "plant description (TOML); default: the documented defaults");
  cmd->add_option("--calibration", options->calibration,
                  "bias calibration (TOML); default: data/calibration_table2.toml");
  cmd->add_option("--sample-rate-hz", options->sample_rate_hz,
                  "gyro (ADS1251) sample rate; fCLK = 384 x rate (ADS1251 data rates up to ~20 kSPS)")
      ->check(CLI::Range(1.0, 20000.0))
      ->capture_default_str();
  cmd->add_option("--seed", options->seed, "noise seed (runs are deterministic for a seed)")
      ->capture_default_str();
  cmd->add_option("--adc-model", options->adc_model,
                  "transaction: each ADS1251 conversion handed over at its DRDY edge, the clock moved as the "
                  "driver's read moves it (the same samples as bit here, where the reader is instant, ~3.5x faster); "
                  "bit: the ADS1251 driver over the bit-level chip simulator, every pin edge")
      ->check(CLI::IsMember({"transaction", "bit"}))
      ->capture_default_str();
  cmd->add_option("--out", options->out,
                  "directory for simulation.csv (1 Hz time series) and summary.json");
  cmd->add_option("--plot", options->plot,
                  "SVG plot, stacked panels on one time axis: temperatures; casing error with the +/-0.3 C "
                  "band; TEC current on the stage's range; bias before and rate after compensation")
      ->check([](const std::string& p) {
        return p.size() >= 4 && p.compare(p.size() - 4, 4, ".svg") == 0 ? std::string() : "only .svg is supported";
      });
  cmd->add_option("--compare", options->compare,
                  "RUN_DIR: overlay another run (the --out folder of an earlier simulate) on --plot, thin black: "
                  "casing, error, TEC current and compensated rate on the same axes");
  cmd->add_option("--rate-csv", options->rate_csv,
                  "write the compensated rate of every ADC sample in --rate-window (time_s,rate_dps) for "
                  "`gyrotc allan`");
  cmd->add_option("--rate-window", options->rate_window,
                  "START:END in seconds from the profile's start: the (steady) segment --rate-csv records");
  cmd->add_flag("--json", options->json, "print the summary as one JSON object");
  cmd->callback([options, cmd] {
    if (cmd->count("--experiment-scale") > 0 && options->profile != "tune") {
      throw InputError("--experiment-scale: only with --profile tune");
    }
    if (cmd->count("--ambient-step-c") > 0 && options->profile != "tune") {
      throw InputError("--ambient-step-c: only with --profile tune");
    }
    run(*options);
  });
}

}  // namespace gyrotc::app
