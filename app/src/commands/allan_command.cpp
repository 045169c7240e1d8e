// `gyrotc allan`: noise characterisation of a rate record (issue 9): the
// overlapping Allan deviation (IEEE Std 952) with its confidence interval,
// the angle random walk N, bias instability B and rate random walk K, and an
// optional log-log SVG plot with the slope lines.

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/app/commands.hpp"
#include "gyrotc/app/csv_table.hpp"
#include "gyrotc/app/errors.hpp"
#include "gyrotc/app/svg_plot.hpp"
#include "gyrotc/app/output_path.hpp"

namespace gyrotc::app {
namespace {

struct AllanOptions {
  std::string data;
  std::string column = "rate_dps";
  double rate_hz = 0.0;  // 0: from time_s
  std::string plot;
  bool json = false;
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

plot::Figure allan_figure(const stats::AllanResult& r, const std::string& title, const std::string& column) {
  plot::Figure f;
  f.title = title;
  f.x.title = "cluster time tau (s)";
  f.x.scale = plot::Scale::log;
  plot::Panel p;
  p.y.title = "Allan deviation (" + column + ")";
  p.y.scale = plot::Scale::log;
  plot::Series adev, lo, hi;
  adev.label = "overlapping Allan deviation";
  adev.color = "#1f77b4";
  lo.label = "1-sigma interval";
  hi.label = "";
  lo.color = hi.color = "#9ecae1";
  for (const auto& pt : r.points) {
    adev.x.push_back(pt.tau_s);
    adev.y.push_back(pt.adev);
    lo.x.push_back(pt.tau_s);
    lo.y.push_back(pt.ci_low);
    hi.x.push_back(pt.tau_s);
    hi.y.push_back(pt.ci_high);
  }
  const double t0 = r.points.front().tau_s;
  const double t1 = r.points.back().tau_s;
  p.series = {adev, lo, hi};
  char label[96];
  if (r.arw.value_at_ref > 0.0) {
    std::snprintf(label, sizeof label, "N = %.3g /sqrt(s) (slope -1/2, at 1 s)", r.arw.value_at_ref);
    p.series.push_back(plot::power_law_line(label, r.arw.value_at_ref, 1.0, -0.5, t0, t1, "#d62728"));
  }
  if (r.rrw.value_at_ref > 0.0) {
    std::snprintf(label, sizeof label, "K = %.3g /s/sqrt(s) (slope +1/2, at 3 s)", r.rrw.value_at_ref);
    p.series.push_back(plot::power_law_line(label, r.rrw.value_at_ref, 3.0, 0.5, t0, t1, "#2ca02c"));
  }
  if (r.bias_instability.valid) {
    std::snprintf(label, sizeof label, "0.664 B, B = %.3g (flat minimum / 0.664)", r.bias_instability.value_at_ref);
    p.series.push_back(plot::power_law_line(label, 0.664 * r.bias_instability.value_at_ref, 1.0, 0.0, t0, t1, "#ff7f0e"));
  }
  f.panels = {p};
  return f;
}

void run(const AllanOptions& o) {
  if (!o.plot.empty() && !ends_with(o.plot, ".svg")) {
    throw InputError("--plot " + o.plot + ": only .svg is supported");
  }
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  const CsvTable table = CsvTable::read(o.data);
  const std::vector<double> rate = table.numbers(o.column);  // names file/line/column of a bad cell
  if (rate.size() < 2) {
    throw InputError(o.data + ": column '" + o.column + "' has " + std::to_string(rate.size()) +
                     " sample(s); the Allan deviation needs at least 2");
  }
  const double rate_hz = o.rate_hz > 0.0 ? o.rate_hz : rate_from_time(table);
  stats::AllanResult r;
  try {
    r = stats::allan_deviation(rate, rate_hz);
  } catch (const std::invalid_argument& e) {
    throw InputError(o.data + ": " + e.what());
  }
  if (!o.plot.empty()) {
    plot::write_svg(allan_figure(r, "Allan deviation of " + o.data + " (" + o.column + ")", o.column), o.plot);
  }
  const double n = r.arw.value_at_ref;
  const double b = r.bias_instability.value_at_ref;
  const double k = r.rrw.value_at_ref;
  if (o.json) {
    nlohmann::json j;
    j["data"] = o.data;
    j["column"] = o.column;
    j["samples"] = r.samples;
    j["rate_hz"] = r.rate_hz;
    std::vector<double> tau, adev, lo, hi;
    for (const auto& p : r.points) {
      tau.push_back(p.tau_s);
      adev.push_back(p.adev);
      lo.push_back(p.ci_low);
      hi.push_back(p.ci_high);
    }
    j["tau_s"] = tau;
    j["adev_dps"] = adev;
    j["adev_ci_low_dps"] = lo;
    j["adev_ci_high_dps"] = hi;
    j["arw_deg_per_rt_h"] = stats::arw_deg_per_rt_h(n);
    j["bias_instability_deg_per_h"] = stats::bias_deg_per_h(b);
    j["bias_instability_tau_s"] = r.bias_instability.ref_tau_s;
    j["rrw_deg_per_h_per_rt_h"] = stats::rrw_deg_per_h_per_rt_h(k);
    if (!o.plot.empty()) j["plot"] = o.plot;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("gyrotc allan: %s, column %s: %zu samples at %g Hz (%.0f s)\n", o.data.c_str(), o.column.c_str(),
              r.samples, r.rate_hz, static_cast<double>(r.samples) / r.rate_hz);
  std::printf("  %12s %14s %14s %14s\n", "tau_s", "adev_dps", "ci_low_dps", "ci_high_dps");
  for (const auto& p : r.points) {
    std::printf("  %12.4g %14.5g %14.5g %14.5g\n", p.tau_s, p.adev, p.ci_low, p.ci_high);
  }
  std::printf("  angle random walk N     %.4g deg/sqrt(h)   (slope -1/2 line at tau = 1 s)\n",
              stats::arw_deg_per_rt_h(n));
  std::printf("  bias instability B      %.4g deg/h         (minimum at tau = %.3g s, / 0.664)\n",
              stats::bias_deg_per_h(b), r.bias_instability.ref_tau_s);
  std::printf("  rate random walk K      %.4g deg/h/sqrt(h) (slope +1/2 line at tau = 3 s)\n",
              stats::rrw_deg_per_h_per_rt_h(k));
  if (!o.plot.empty()) std::printf("  plot: %s\n", o.plot.c_str());
}

}  // namespace

void add_allan_command(CLI::App& app) {
  auto options = std::make_shared<AllanOptions>();
  CLI::App* cmd = app.add_subcommand(
      "allan",
      "Noise characterisation (IEEE Std 952): overlapping Allan deviation of a rate record at\n"
      "log-spaced cluster times (10 per decade) with a 1-sigma interval 1/sqrt(2(n/m - 1)), and the\n"
      "angle random walk N (slope -1/2, at 1 s), bias instability B (minimum / 0.664) and rate random\n"
      "walk K (slope +1/2, at 3 s) from a non-negative least-squares fit of the standard terms.\n"
      "The rate is taken as deg/s. Records: `gyrotc simulate --rate-csv` or any CSV with the column.");
  cmd->add_option("--data", options->data, "CSV record with a header row")->required();
  cmd->add_option("--column", options->column, "rate column (deg/s)")->capture_default_str();
  cmd->add_option("--rate-hz", options->rate_hz,
                  "sample rate; default: (samples - 1) / span of the strictly increasing time_s column")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--plot", options->plot, "log-log plot with the slope lines (SVG only: FILE.svg)");
  cmd->add_flag("--json", options->json,
                "print one JSON object: samples, rate_hz, tau_s, adev_dps, adev_ci_low_dps, adev_ci_high_dps, "
                "arw_deg_per_rt_h, bias_instability_deg_per_h, rrw_deg_per_h_per_rt_h");
  cmd->callback([options] { run(*options); });
}

}  // namespace gyrotc::app
