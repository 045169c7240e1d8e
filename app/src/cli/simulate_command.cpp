// `gyrotc simulate`: the closed-loop chamber simulation (issue 4). Runs the
// real Controller on the simulated board in lockstep over a chamber profile
// and prints the summary; optionally writes the 1 Hz time series (CSV) and a
// plot.

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
#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/app/formats/calibration_file.hpp"
#include "gyrotc/app/formats/chamber_profile_file.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/support/data_dir.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc/app/support/progress.hpp"
#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc/app/support/output_path.hpp"
#include "gyrotc/app/workflows/tuning.hpp"

namespace gyrotc::app {
namespace {

struct SimulateOptions {
  std::string profile = "fig26";
  double ambient_c = 16.0;  // --profile tune: the room's temperature
  double experiment_scale = 1.0;  // --profile tune: tune::ExperimentPlan::scaled
  std::string controller = "paper";
  std::string plant;
  std::string calibration;
  double sample_rate_hz = 1000.0;
  std::uint64_t seed = 1;
  std::string out;
  std::string plot;
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

// Temperatures and TEC current above, the rate before/after compensation below.
plot::Figure simulation_figure(const SimulationResult& r, const SimulateOptions& o, double scale_mv_per_dps) {
  plot::Figure f;
  f.title = "gyrotc simulate: profile " + o.profile + ", controller " + o.controller;
  f.x.title = "time (s)";
  plot::Series casing, setpoint, ambient, current, compensated, uncompensated;
  casing.label = "casing (true)";
  setpoint.label = "setpoint";
  ambient.label = "ambient";
  current.label = "TEC current";
  current.right_axis = true;
  compensated.label = "compensated rate";
  uncompensated.label = "uncompensated bias (gyro_mv / scale)";
  for (const auto& row : r.rows) {
    for (auto* s : {&casing, &setpoint, &ambient, &current, &compensated, &uncompensated}) s->x.push_back(row.time_s);
    casing.y.push_back(row.casing_c);
    setpoint.y.push_back(row.setpoint_c);
    ambient.y.push_back(row.ambient_c);
    current.y.push_back(row.tec_a);
    compensated.y.push_back(row.rate_dps_compensated);
    uncompensated.y.push_back(row.gyro_mv / scale_mv_per_dps);
  }
  plot::Panel temps;
  temps.y.title = "temperature (C)";
  temps.y2.title = "TEC current (A)";
  temps.series = {casing, setpoint, ambient, current};
  plot::Panel rate;
  rate.y.title = "rate (deg/s), 1 s means";
  rate.series = {uncompensated, compensated};
  f.panels = {temps, rate};
  return f;
}

std::string default_calibration_path() { return data_dir() + "/calibration_table2.toml"; }

nlohmann::json summary_json(const SimulateOptions& o, const std::string& calibration_name,
                            const SimulationResult& r, double wall_s) {
  nlohmann::json j;
  const auto& s = r.summary;
  j["profile"] = o.profile;
  j["controller"] = o.profile == "tune" ? std::string("identification experiment") : o.controller;
  j["calibration"] = calibration_name;
  j["sample_rate_hz"] = o.sample_rate_hz;
  j["seed"] = o.seed;
  j["simulated_s"] = s.simulated_s;
  j["wall_s"] = wall_s;
  j["speedup"] = wall_s > 0.0 ? s.simulated_s / wall_s : 0.0;
  j["samples"] = r.counters.samples;
  // Control figures only where something held the setpoint: with the
  // controller off, or during the identification experiment, a "settle time"
  // or an error from the setpoint means nothing.
  const bool regulated = o.controller != "off" && o.profile != "tune";
  if (regulated) {
    j["settle_s"] = s.settle_s >= 0.0 ? nlohmann::json(s.settle_s) : nlohmann::json(nullptr);
    // null when it never settled: there is no in-band hold to judge, not a zero error.
    j["max_abs_error_c_in_band"] =
        s.settle_s >= 0.0 ? nlohmann::json(s.max_abs_error_c_in_band) : nlohmann::json(nullptr);
  }
  j["bias_uncompensated_max_abs_dps"] = s.bias_uncompensated_max_abs_dps;
  j["bias_compensated_max_abs_dps"] = s.bias_compensated_max_abs_dps;
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
  std::printf("gyrotc simulate: profile %s, controller %s, calibration %s\n",
              j["profile"].get<std::string>().c_str(), j["controller"].get<std::string>().c_str(),
              j["calibration"].get<std::string>().c_str());
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
  std::printf("  %-14s %-14s %16s %14s %14s %14s\n", "segment", "ambient_c", "max_abs_error_c",
              "tec_saturated", "bias_unc_dps", "bias_comp_dps");
  for (const auto& seg : j["segments"]) {
    std::string ambient = seg["ambient_c"].is_array()
                              ? num(seg["ambient_c"][0], "%.0f") + ".." + num(seg["ambient_c"][1], "%.0f")
                              : num(seg["ambient_c"], "%.0f");
    std::printf("  %-14s %-14s %16s %14s %14s %14s\n", seg["segment"].get<std::string>().c_str(),
                ambient.c_str(),
                seg.contains("max_abs_error_c") ? num(seg["max_abs_error_c"], "%.3f").c_str() : "-",
                seg["tec_saturated"].get<bool>() ? "yes" : "no",
                seg.contains("bias_uncompensated_dps") ? num(seg["bias_uncompensated_dps"], "%.3f").c_str() : "-",
                seg.contains("bias_compensated_dps") ? num(seg["bias_compensated_dps"], "%.3f").c_str() : "-");
  }
  if (j.contains("record")) {
    std::printf("  identification experiment: %.0f s at %.1f C ambient%s; record for `gyrotc tune`: %s\n",
                j["experiment"]["duration_s"].get<double>(), j["experiment"]["ambient_c"].get<double>(),
                j["experiment"]["finished"].get<bool>() ? "" : " (did not finish)",
                j["record"].get<std::string>().c_str());
  }
  if (csv) std::printf("  time series (1 Hz CSV): %s\n", csv->c_str());
  if (plot) std::printf("  plot: %s\n", plot->c_str());
}

// A preset by name, or a controller file (tune's output) on the plant's limits.
ControllerConfig controller_for(const std::string& name, const model::PlantParams& plant) {
  if (name == "paper" || name == "tuned" || name == "off") return controller_preset(parse_controller_mode(name), plant);
  if (!std::filesystem::is_regular_file(name)) {
    throw InputError("--controller '" + name + "': neither paper, tuned, off nor a controller file");
  }
  return apply_controller_file(load_controller_file(name), controller_preset(ControllerMode::paper, plant), name);
}

void run(const SimulateOptions& o) {
  if (!o.out.empty()) prepare_output_dir(o.out, "--out");
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  if (!o.rate_csv.empty()) prepare_output_file(o.rate_csv, "--rate-csv");
  const bool experiment = o.profile == "tune";
  const tune::ExperimentPlan plan = tune::ExperimentPlan{}.scaled(o.experiment_scale);
  const model::ChamberProfile profile = experiment ? tune_experiment_room(o.ambient_c, plan)
                                                   : chamber_profile_by_name(o.profile, data_dir());
  SimulationSetup setup;
  if (!o.plant.empty()) setup.plant = load_plant(o.plant);
  setup.seed = o.seed;
  setup.sample_rate_hz = o.sample_rate_hz;
  setup.controller = controller_for(experiment ? std::string("paper") : o.controller, setup.plant);
  tune::IdentificationExperiment program(plan);
  if (experiment) setup.program = &program;
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
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.finish();

  std::optional<std::string> csv_path;
  std::optional<std::string> plot_path;
  if (!o.plot.empty()) {
    plot::write_svg(simulation_figure(result, o, setup.scale_mv_per_dps), o.plot);
    plot_path = o.plot;
  }
  nlohmann::json j = summary_json(o, calibration_name, result, wall_s);
  if (experiment) {
    j["experiment"] = {{"ambient_c", o.ambient_c},
                       {"duration_s", result.rows.empty() ? 0.0 : result.rows.back().time_s},
                       {"finished", program.phase() == tune::ExperimentPhase::done}};
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
                  "soaks, seed Section 4.2), a CSV file (time_s,ambient_c or the fig26 segment format), or "
                  "tune: the identification experiment of `gyrotc tune` (<= 3 h at --ambient-c; writes "
                  "record.csv, the board's record, into --out)")
      ->capture_default_str();
  cmd->add_option("--ambient-c", options->ambient_c, "--profile tune: the room's (chamber's) constant temperature")
      ->check(CLI::Range(-40.0, 80.0))
      ->capture_default_str();
  cmd->add_option("--experiment-scale", options->experiment_scale,
                  "--profile tune on a plant faster than the reference: every phase's length times this factor "
                  "(0 < F <= 1), as gyrotc record --experiment-scale")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  cmd->add_option("--controller", options->controller,
                  "paper: the seed's integral-separated PID; tuned: ours (retuned gains, feed-forward "
                  "from the ambient sensor); off: TEC off, compensation only; or a controller file "
                  "(TOML) as `gyrotc tune` writes it")
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
  cmd->add_option("--out", options->out,
                  "directory for simulation.csv (1 Hz time series) and summary.json");
  cmd->add_option("--plot", options->plot,
                  "SVG plot: casing, setpoint and ambient temperature with the TEC current; the rate before "
                  "and after compensation")
      ->check([](const std::string& p) {
        return p.size() >= 4 && p.compare(p.size() - 4, 4, ".svg") == 0 ? std::string() : "only .svg is supported";
      });
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
    run(*options);
  });
}

}  // namespace gyrotc::app
