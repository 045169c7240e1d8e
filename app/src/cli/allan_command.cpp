// `gyrotc allan`: noise characterisation of a rate record (issues 9, 20): the
// overlapping Allan deviation (IEEE Std 952) with EDF-based intervals, the
// noise terms the record supports with their intervals, and an optional
// log-log SVG plot with the terms' lines and the fitted model.

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc/app/support/output_path.hpp"

namespace gyrotc::app {
namespace {

struct AllanOptions {
  std::string data;
  std::string column = "rate_dps";
  double rate_hz = 0.0;  // 0: from time_s
  std::string plot;
  bool json = false;
  double confidence = 0.95;
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The sample rate from time_s: (samples - 1) / span. The column must be
// strictly increasing; a spread of intervals is reported, not fatal: the
// Allan deviation assumes even sampling, which the recorder provides.
double rate_from_time(const CsvTable& table) {
  if (!table.has("time_s")) {
    throw InputError(table.path() + ": no 'time_s' column to take the sample rate from; give --rate-hz");
  }
  table.require_increasing("time_s");
  const std::vector<double> t = table.numbers("time_s");
  return static_cast<double>(t.size() - 1) / (t.back() - t.front());
}

// A term in the units people quote: Q deg, N deg/sqrt(h),
// B deg/h, K deg/h/sqrt(h), R deg/h/h.
struct Quoted {
  const char* json_key;
  const char* label;
  const char* unit;
  double scale;  // from the fit's deg/s-based unit
};

Quoted quoted(stats::NoiseTerm t) {
  switch (t) {
    case stats::NoiseTerm::quantisation: return {"quantisation_deg", "quantisation Q", "deg", 1.0};
    case stats::NoiseTerm::angle_random_walk:
      return {"arw_deg_per_rt_h", "angle random walk N", "deg/sqrt(h)", stats::arw_deg_per_rt_h(1.0)};
    case stats::NoiseTerm::bias_instability:
      return {"bias_instability_deg_per_h", "bias instability B", "deg/h", stats::bias_deg_per_h(1.0)};
    case stats::NoiseTerm::rate_random_walk:
      return {"rrw_deg_per_h_per_rt_h", "rate random walk K", "deg/h/sqrt(h)", stats::rrw_deg_per_h_per_rt_h(1.0)};
    case stats::NoiseTerm::rate_ramp: return {"rate_ramp_deg_per_h2", "rate ramp R", "deg/h^2", 3600.0 * 3600.0};
  }
  return {"", "", "", 1.0};
}

// A rate in deg/s (a column named *_dps) is drawn in deg/h, the unit its
// fitted terms are quoted in (N in deg/sqrt(h), B in deg/h, K in deg/h/sqrt(h)).
plot::Figure allan_figure(const stats::AllanResult& r, const std::string& title, const std::string& column,
                          double confidence) {
  const bool dps = ends_with(column, "_dps");
  const double scale = dps ? 3600.0 : 1.0;
  plot::Figure f;
  f.title = title;
  f.x.title = "cluster time τ (s)";
  f.x.scale = plot::Scale::log;
  f.legend_width_px = 230.0;
  plot::Panel p;
  p.y.title = dps ? "Allan deviation (°/h)" : "Allan deviation (" + column + ")";
  p.y.scale = plot::Scale::log;
  plot::Series adev, hdev, lo, hi;
  adev.label = "Allan deviation";
  adev.color = "#1f77b4";
  hdev.label = "Hadamard deviation";
  hdev.color = "#17becf";
  hdev.dashed = true;
  char label[160];
  std::snprintf(label, sizeof label, "%.0f %% interval of the Allan dev.", 100.0 * confidence);
  lo.label = label;
  lo.color = hi.color = "#9ecae1";
  for (const auto& pt : r.points) {
    adev.x.push_back(pt.tau_s);
    adev.y.push_back(pt.adev * scale);
    lo.x.push_back(pt.tau_s);
    lo.y.push_back(pt.ci_low * scale);
    hi.x.push_back(pt.tau_s);
    hi.y.push_back(pt.ci_high * scale);
    if (pt.hdev > 0.0) {
      hdev.x.push_back(pt.tau_s);
      hdev.y.push_back(pt.hdev * scale);
    }
  }
  const double t0 = r.points.front().tau_s;
  const double t1 = r.points.back().tau_s;
  p.series = {adev, lo, hi};
  if (!hdev.x.empty()) p.series.push_back(hdev);
  const char* colors[] = {"#9467bd", "#d62728", "#ff7f0e", "#2ca02c", "#8c564b"};
  for (stats::NoiseTerm t : stats::kAllNoiseTerms) {
    const stats::TermEstimate& e = r.fit.term(t);
    if (!e.included) continue;
    const Quoted q = quoted(t);
    const int power = stats::noise_term_power(t);
    static const char* slopes[] = {"-1", "-1/2", "0", "+1/2", "+1"};
    const std::string symbol = std::string(q.label).substr(std::string(q.label).rfind(' ') + 1);
    std::snprintf(label, sizeof label, "%s = %.3g %s (slope %s)", symbol.c_str(), e.value * q.scale, q.unit,
                  slopes[static_cast<std::size_t>(power + 2)]);
    // ADEV of the term alone: sqrt(c) tau^(power / 2), drawn through tau = 1 s.
    p.series.push_back(plot::power_law_line(label, scale * std::sqrt(stats::avar_coefficient(t, e.value)), 1.0,
                                            0.5 * power, t0, t1, colors[static_cast<std::size_t>(t)]));
  }
  plot::Series model;
  model.label = "fitted model";
  model.color = "#000000";
  for (const auto& pt : r.points) {
    model.x.push_back(pt.tau_s);
    model.y.push_back(scale * std::sqrt(r.fit.avar(pt.tau_s)));
  }
  if (r.fit.valid) p.series.push_back(model);
  f.panels = {p};
  return f;
}

void run(const AllanOptions& o) {
  if (!o.plot.empty() && !ends_with(o.plot, ".svg")) {
    throw InputError("--plot " + o.plot + ": only .svg is supported");
  }
  if (!(o.confidence > 0.0 && o.confidence < 1.0)) throw InputError("--confidence: must lie between 0 and 1");
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  const CsvTable table = CsvTable::read(o.data);
  const std::vector<double> rate = table.numbers(o.column);  // names file/line/column of a bad cell
  if (rate.size() < 2) {
    throw InputError(o.data + ": column '" + o.column + "' has " + std::to_string(rate.size()) +
                     " sample(s); the Allan deviation needs at least 2");
  }
  const double rate_hz = o.rate_hz > 0.0 ? o.rate_hz : rate_from_time(table);
  stats::AllanOptions so;
  so.confidence = o.confidence;
  stats::AllanResult r;
  try {
    r = stats::allan_deviation(rate, rate_hz, so);
  } catch (const std::invalid_argument& e) {
    throw InputError(o.data + ": " + e.what());
  }
  if (!o.plot.empty()) {
    plot::write_svg(allan_figure(r, "Allan deviation of " + o.data + " (" + o.column + ")", o.column, o.confidence),
                    o.plot);
  }
  if (o.json) {
    nlohmann::json j;
    j["data"] = o.data;
    j["column"] = o.column;
    j["samples"] = r.samples;
    j["rate_hz"] = r.rate_hz;
    j["confidence"] = o.confidence;
    std::vector<double> tau, adev, lo, hi, edf;
    nlohmann::json hdev = nlohmann::json::array();
    for (const auto& p : r.points) {
      tau.push_back(p.tau_s);
      adev.push_back(p.adev);
      hdev.push_back(p.hdev > 0.0 ? nlohmann::json(p.hdev) : nlohmann::json(nullptr));
      lo.push_back(p.ci_low);
      hi.push_back(p.ci_high);
      edf.push_back(p.edf);
    }
    j["tau_s"] = tau;
    j["adev_dps"] = adev;
    j["adev_ci_low_dps"] = lo;
    j["adev_ci_high_dps"] = hi;
    j["adev_edf"] = edf;
    j["hdev_dps"] = hdev;
    for (stats::NoiseTerm t : stats::kAllNoiseTerms) {
      const stats::TermEstimate& e = r.fit.term(t);
      const Quoted q = quoted(t);
      const std::string key = q.json_key;
      j[key] = e.included ? nlohmann::json(e.value * q.scale) : nlohmann::json(nullptr);
      j[key + "_ci"] = e.included ? nlohmann::json{e.ci_low * q.scale, e.ci_high * q.scale} : nlohmann::json(nullptr);
      j[key + "_upper"] = !e.included && e.upper_bound > 0.0 ? nlohmann::json(e.upper_bound * q.scale) : nlohmann::json(nullptr);
      j[key + "_if_present"] =
          !e.included && e.value_if_present > 0.0 ? nlohmann::json(e.value_if_present * q.scale) : nlohmann::json(nullptr);
    }
    j["fit_valid"] = r.fit.valid;
    if (!o.plot.empty()) j["plot"] = o.plot;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("gyrotc allan: %s, column %s: %zu samples at %g Hz (%.0f s)\n", o.data.c_str(), o.column.c_str(),
              r.samples, r.rate_hz, static_cast<double>(r.samples) / r.rate_hz);
  std::printf("  %12s %14s %10s %14s %14s %14s   (%.0f %% interval)\n", "tau_s", "adev_dps", "edf", "ci_low_dps",
              "ci_high_dps", "hdev_dps", 100.0 * o.confidence);
  for (const auto& p : r.points) {
    char hdev[32] = "-";
    if (p.hdev > 0.0) std::snprintf(hdev, sizeof hdev, "%.5g", p.hdev);
    std::printf("  %12.4g %14.5g %10.4g %14.5g %14.5g %14s\n", p.tau_s, p.adev, p.edf, p.ci_low, p.ci_high, hdev);
  }
  if (!r.fit.valid) {
    std::printf("  noise terms: too few points to fit\n");
    return;
  }
  std::printf("  noise terms (%.0f %% intervals; a term is reported only when the data support it):\n",
              100.0 * o.confidence);
  for (stats::NoiseTerm t : stats::kAllNoiseTerms) {
    const stats::TermEstimate& e = r.fit.term(t);
    const Quoted q = quoted(t);
    if (e.included) {
      std::printf("  %-22s %10.4g %-14s [%.4g, %.4g]\n", q.label, e.value * q.scale, q.unit, e.ci_low * q.scale,
                  e.ci_high * q.scale);
    } else if (e.upper_bound > 0.0) {
      std::printf("  %-22s %10s %-14s not resolved; below %.4g; %.4g if present\n", q.label, "-", q.unit,
                  e.upper_bound * q.scale, e.value_if_present * q.scale);
    } else {
      std::printf("  %-22s %10s %-14s not resolved\n", q.label, "-", q.unit);
    }
  }
  if (!o.plot.empty()) std::printf("  plot: %s\n", o.plot.c_str());
}

}  // namespace

void add_allan_command(CLI::App& app) {
  auto options = std::make_shared<AllanOptions>();
  CLI::App* cmd = app.add_subcommand(
      "allan",
      "Noise characterisation (IEEE Std 952): overlapping Allan deviation of a rate record at\n"
      "log-spaced cluster times (10 per decade), each with a chi-square interval from its equivalent\n"
      "degrees of freedom (Greenhall's algorithm for the fitted mixture of noise types), and the\n"
      "terms quantisation Q, angle random walk N, bias instability B, rate random walk K and rate\n"
      "ramp R fitted by maximum likelihood over every cluster time, each with its interval; a term is\n"
      "reported only when an information criterion supports it, and a term not resolved gets an upper\n"
      "bound and its value if present. Where K hides under another noise at short tau, its value\n"
      "comes from restricted maximum likelihood on the differences of 500 block means of the\n"
      "record. The rate is taken as deg/s.\n"
      "Records: `gyrotc simulate --rate-csv` or any CSV with the column.");
  cmd->add_option("--data", options->data, "CSV record with a header row")->required();
  cmd->add_option("--column", options->column, "rate column (deg/s)")->capture_default_str();
  cmd->add_option("--rate-hz", options->rate_hz,
                  "sample rate; default: (samples - 1) / span of the strictly increasing time_s column")
      ->check(positive_number());
  cmd->add_option("--plot", options->plot, "log-log plot with the slope lines (SVG only: FILE.svg)");
  cmd->add_option("--confidence", options->confidence, "confidence of the intervals")->capture_default_str();
  cmd->add_flag("--json", options->json,
                "print one JSON object: samples, rate_hz, confidence, tau_s, adev_dps, adev_ci_low_dps,\n"
                "adev_ci_high_dps, adev_edf, and per term quantisation_deg, arw_deg_per_rt_h,\n"
                "bias_instability_deg_per_h, rrw_deg_per_h_per_rt_h, rate_ramp_deg_per_h2 (null when not\n"
                "resolved) with its interval as KEY_ci = [low, high], or for a term not resolved KEY_upper,\n"
                "its upper bound, and KEY_if_present, its value if present (docs/ALLAN.md)");
  cmd->callback([options] { run(*options); });
}

}  // namespace gyrotc::app
