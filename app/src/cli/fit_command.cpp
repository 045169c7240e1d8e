// `gyrotc fit`: turns a chamber run (Table 2-like CSV, or a time series binned
// by temperature) into a zero-bias model, reports in-sample and leave-one-out
// errors, compares the methods side by side, and writes the calibration file.

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/algorithms/calibrate/calibration_bound.hpp"
#include "gyrotc/algorithms/calibrate/die_temperature.hpp"
#include "gyrotc/algorithms/calibrate/temperature_bins.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/fit/cross_validation.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc/algorithms/fit/record_screen.hpp"
#include "gyrotc/algorithms/stats/summary.hpp"
#include "gyrotc/app/formats/calibration_file.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/progress.hpp"
#include "gyrotc/app/support/output_path.hpp"

namespace gyrotc::app {
namespace {

using nlohmann::ordered_json;

struct FitOptions {
  std::string data;
  std::string method = "auto";
  std::vector<int> orders;
  std::vector<double> breakpoints_c;
  std::string continuity = "value";
  std::string criterion = "loo";
  std::optional<double> cv_block_c;  // default: two bins for a time series, none for a table
  std::string penalty = "jumps";
  double dof = 0.0;
  std::string out;
  std::string plot;
  bool json = false;
  bool compare = false;
  bool nested = true;
  std::uint64_t seed = 1;
  std::vector<int> hidden = {10, 10, 10};
  int restarts = 3;
  double bin_width_c = 1.0;
  double die_lag_s = 0.0;  // a time series binned by the die's temperature (calibrate/die_temperature.hpp)
  double die_lag_s_std = 0.0;  // its standard error, where it was measured (`calibrate`): the bound draws from it
  bool bound = true;           // the calibration's own error bound (calibrate/calibration_bound.hpp)
  int bound_replicates = 200;
  double scale_mv_per_dps = fit::Compensator::kSeedScaleMvPerDps;
  std::vector<std::string> accept;  // record checks overridden: span, uneven, unsettled
  nlohmann::json extra_json = nlohmann::json::object();  // a caller's keys added to the --json summary
};

struct Points {
  std::vector<double> temp_c;
  std::vector<double> gyro_mv;
  std::string kind;                   // "table" or "time series (N samples, W C bins)"
  std::size_t samples = 0;            // a time series' rows (0: a table)
  std::vector<std::string> accepted;  // "check: reason" of each refusal --accept overrode
  // A time series' rows, for the bound's bootstrap (empty for a table).
  std::vector<double> time_s;
  std::vector<double> sensor_c;
  std::vector<double> series_gyro_mv;
};

// A Table 2-like file: one row per temperature.
Points read_table(const CsvTable& table) {
  Points p;
  p.temp_c = table.numbers("temp_c");
  p.gyro_mv = table.numbers("gyro_mv");
  std::map<double, std::size_t> seen;  // temperature -> row
  for (std::size_t r = 0; r < p.temp_c.size(); ++r) {
    const auto [it, fresh] = seen.emplace(p.temp_c[r], r);
    if (!fresh) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%g", p.temp_c[r]);
      throw InputError(table.path() + ":" + std::to_string(table.line_of(r)) + ": temp_c " + buf +
                       " repeats the temperature of line " + std::to_string(table.line_of(it->second)) +
                       " (average repeated runs into one row)");
    }
  }
  p.kind = "table";
  return p;
}

// What to do about each refusal of fit::screen_calibration_record.
const char* screen_advice(fit::ScreenCheck check) {
  switch (check) {
    case fit::ScreenCheck::held:
      return "record the sweep with the loop off (`gyrotc record --pid off`, the chamber sweeping)";
    case fit::ScreenCheck::span:
      return "sweep a wider range (or --accept span)";
    case fit::ScreenCheck::uneven:
      return "hold every temperature about as long, or bin wider with --bin-width (or --accept uneven)";
    case fit::ScreenCheck::unsettled:
      return "sweep slower or hold each temperature until it settles (or --accept unsettled)";
  }
  return "";
}

// A record that cannot calibrate is refused before the fit (the fit would
// still make a model, and a flattering error figure).
std::vector<std::string> screen_record(const CsvTable& table, const std::vector<double>& time_s,
                                       const std::vector<double>& sensor_c, const FitOptions& o) {
  fit::RecordSamples record{time_s, sensor_c, std::nullopt, std::nullopt};
  std::vector<double> setpoint_c;
  if (table.has("setpoint_c") && table.has("flags")) {
    setpoint_c = table.numbers("setpoint_c");
    const std::vector<double> flags = table.numbers("flags");
    std::vector<bool> tec_on;
    for (std::size_t r = 0; r < flags.size(); ++r) {
      if (!(flags[r] >= 0.0 && flags[r] <= 4294967295.0 && flags[r] == std::floor(flags[r]))) {
        throw InputError(table.path() + ":" + std::to_string(table.line_of(r)) +
                         ": flags must be the controller's flag word, a whole number 0 .. 4294967295");
      }
      tec_on.push_back((static_cast<std::uint32_t>(flags[r]) & kFlagTecOff) == 0);
    }
    record.setpoint_c = std::span<const double>(setpoint_c);
    record.tec_on = std::move(tec_on);
  }
  fit::ScreenLimits limits;
  limits.bin_width_c = o.bin_width_c;
  if (!o.orders.empty()) {
    const int order = *std::max_element(o.orders.begin(), o.orders.end());
    limits.min_bins = std::max(limits.min_bins, static_cast<std::size_t>(3 * (order + 1)));
  }
  std::vector<std::string> accepted;
  for (const fit::ScreenFinding& f : fit::screen_calibration_record(record, limits)) {
    const std::string name = fit::screen_check_name(f.check);
    // --accept takes span, uneven and unsettled only: held is never overridden.
    if (std::find(o.accept.begin(), o.accept.end(), name) == o.accept.end()) {
      throw InputError(table.path() + ": cannot calibrate (" + name + "): " + f.reason + "; " +
                       screen_advice(f.check));
    }
    std::fprintf(stderr, "gyrotc fit: warning: %s: accepted (%s): %s\n", table.path().c_str(), name.c_str(),
                 f.reason.c_str());
    accepted.push_back(name + ": " + f.reason);
  }
  return accepted;
}

// A recording (time_s, sensor_c, gyro_mv): averaged in temperature bins.
Points read_series(const CsvTable& table, const FitOptions& o) {
  const double bin_width_c = o.bin_width_c;
  table.require_increasing("time_s");
  const std::vector<double> time_s = table.numbers("time_s");
  const std::vector<double> sensor_c = table.numbers("sensor_c");
  const std::vector<double> gyro = table.numbers("gyro_mv");
  // The screen judges how the casing moved; the bins take each sample's bias
  // at the die's temperature when the die's lag is given.
  std::vector<std::string> accepted = screen_record(table, time_s, sensor_c, o);
  const std::vector<double> temp = calibrate::die_temperature_c(time_s, sensor_c, o.die_lag_s);
  calibrate::TemperatureBins bins = calibrate::bin_by_temperature(temp, gyro, bin_width_c);
  Points p;
  p.temp_c = std::move(bins.temp_c);
  p.gyro_mv = std::move(bins.gyro_mv);
  char buf[160];
  if (o.die_lag_s > 0.0) {
    std::snprintf(buf, sizeof buf, "time series, %zu samples in %g C bins of the die (the sensor through a %.1f s lag)",
                  temp.size(), bin_width_c, o.die_lag_s);
  } else {
    std::snprintf(buf, sizeof buf, "time series, %zu samples in %g C bins", temp.size(), bin_width_c);
  }
  p.kind = buf;
  p.samples = temp.size();
  p.accepted = std::move(accepted);
  p.time_s = time_s;
  p.sensor_c = sensor_c;
  p.series_gyro_mv = gyro;
  return p;
}

Points read_points(const FitOptions& o) {
  const CsvTable table = CsvTable::read(o.data);
  if (table.has("temp_c")) {
    if (o.die_lag_s > 0.0) {
      throw InputError(o.data + ": --die-lag-s: a table of temperatures has no time to lag over (it applies to a "
                                "recording with time_s, sensor_c, gyro_mv)");
    }
    return read_table(table);
  }
  if (table.has("sensor_c")) return read_series(table, o);
  std::string have;
  for (const auto& c : table.columns()) have += (have.empty() ? "" : ", ") + c;
  throw InputError(o.data + ": missing column 'temp_c' (a table with temp_c, gyro_mv) or 'sensor_c' (a "
                            "time series with time_s, sensor_c, gyro_mv); columns: " + have);
}

fit::Continuity parse_continuity(const std::string& name) {
  if (name == "none") return fit::Continuity::none;
  if (name == "value") return fit::Continuity::value;
  if (name == "slope") return fit::Continuity::slope;
  throw InputError("--continuity: expected none, value or slope, got '" + name + "'");
}

fit::SmoothingOptions smoothing_options(const FitOptions& o) {
  fit::SmoothingOptions so;
  if (o.criterion == "gcv") so.criterion = fit::SmoothingCriterion::gcv;
  else if (o.criterion != "loo") throw InputError("--criterion: expected loo or gcv, got '" + o.criterion + "'");
  if (o.penalty == "curvature") so.penalty = fit::SmoothingPenalty::curvature;
  else if (o.penalty != "jumps") throw InputError("--penalty: expected jumps or curvature, got '" + o.penalty + "'");
  so.dof = o.dof;
  return so;
}

// The held-out block: a recording's neighbouring bins are crossed one after
// the other and share the gyro's correlated noise (its bias wanders over
// minutes; a sweep at 0.6 C/min crosses a 1 C bin in 100 s), so each bin is
// predicted without the bins within two widths of it. A table's rows are
// separate soaks: leave one out.
double cv_block_c(const FitOptions& o, const Points& p) {
  const double block_c = o.cv_block_c.value_or(p.samples > 0 ? 2.0 * o.bin_width_c : 0.0);
  const auto [lo, hi] = std::minmax_element(p.temp_c.begin(), p.temp_c.end());
  // A wider block leaves the folds too little to fit and to tell models apart.
  const double widest_c = 0.25 * (*hi - *lo);
  if (block_c > widest_c) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "--cv-block %g: wider than a quarter of the data's %.1f C range (at most %.1f C)",
                  block_c, *hi - *lo, widest_c);
    throw InputError(buf);
  }
  return block_c;
}

fit::MethodOptions method_options(const FitOptions& o, fit::Method m, const Points& p) {
  fit::MethodOptions mo;
  mo.method = m;
  mo.orders = o.orders;
  mo.breakpoints_c = o.breakpoints_c;
  mo.continuity = parse_continuity(o.continuity);
  mo.smoothing = smoothing_options(o);
  mo.cv_block_c = cv_block_c(o, p);
  mo.bp.seed = o.seed;
  mo.bp.hidden = o.hidden;
  mo.bp.restarts = o.restarts;
  return mo;
}

// Runs a fit; the algorithms' invalid_argument is the user's data or options.
fit::MethodFit run_fit(const Points& p, const fit::MethodOptions& mo, const std::string& path) {
  try {
    return fit::fit_method(p.temp_c, p.gyro_mv, mo);
  } catch (const std::invalid_argument& e) {
    const std::string name(fit::method_name(mo.method));
    const std::string what = e.what();
    throw InputError(path + ": " + (what.rfind(name, 0) == 0 ? what : name + ": " + what));
  }
}

std::vector<double> run_nested(const Points& p, const fit::MethodOptions& mo, const std::string& path) {
  try {
    return fit::nested_loo_residuals(p.temp_c, p.gyro_mv, mo);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": nested LOO: " + e.what());
  }
}

// Mean cost of one Compensator::compensate call over a temperature sweep.
double ns_per_sample(const fit::BiasModel& model, double scale) {
  const fit::Compensator comp(model, scale);
  const double lo = model.t_min_c();
  const double span = model.t_max_c() - lo;
  volatile double sink = 0.0;
  std::size_t calls = 0;
  const auto start = std::chrono::steady_clock::now();
  std::chrono::duration<double> elapsed{};
  do {
    double acc = 0.0;
    for (int i = 0; i < 4096; ++i) acc += comp.compensate(80.0, lo + span * (i / 4095.0)).rate_dps;
    sink = sink + acc;
    calls += 4096;
    elapsed = std::chrono::steady_clock::now() - start;
  } while (elapsed.count() < 0.02);
  return elapsed.count() * 1e9 / static_cast<double>(calls);
}

ordered_json polynomial_json(const fit::Polynomial& p) {
  return ordered_json{{"center_c", p.center_c},
                      {"scale_c", p.scale_c},
                      {"range_c", {p.t_min_c, p.t_max_c}},
                      {"coefficients_mv", p.coefficients_mv}};
}

ordered_json model_json(const fit::BiasModel& m) {
  ordered_json j{{"kind", m.kind_name()}, {"range_c", {m.t_min_c(), m.t_max_c()}}, {"parameters", m.parameter_count()}};
  if (const auto* p = m.as_polynomial()) {
    j["polynomial"] = polynomial_json(*p);
  } else if (const auto* pw = m.as_piecewise()) {
    ordered_json segs = ordered_json::array();
    for (const auto& s : pw->segments) segs.push_back(polynomial_json(s));
    j["breakpoints_c"] = pw->breakpoints_c;
    j["segments"] = segs;
  } else if (const auto* sp = m.as_spline()) {
    j["knots_c"] = sp->knots_c;
    j["values_mv"] = sp->values_mv;
    j["second_derivatives"] = sp->second_derivatives;
  } else if (const auto* net = m.as_bp_network()) {
    ordered_json layers = ordered_json::array();
    for (std::size_t i = 0; i < net->layers.size(); ++i) {
      const auto& l = net->layers[i];
      layers.push_back({{"inputs", l.inputs},
                        {"outputs", l.outputs},
                        {"activation", i + 1 == net->layers.size() ? "linear" : "tansig"},
                        {"weights", l.weights},
                        {"biases", l.biases}});
    }
    j["out_center_mv"] = net->out_center_mv;
    j["out_half_range_mv"] = net->out_half_range_mv;
    j["layers"] = layers;
  }
  return j;
}

std::string numbers_text(const std::vector<double>& v) {
  std::string s = "[";
  char buf[40];
  for (std::size_t i = 0; i < v.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.10g", i ? ", " : "", v[i]);
    s += buf;
  }
  return s + "]";
}

// Upper minus lower segment at breakpoint i.
double breakpoint_step_mv(const fit::Piecewise& pw, std::size_t i) {
  const double b = pw.breakpoints_c[i];
  return fit::evaluate(pw.segments[i + 1], b) - fit::evaluate(pw.segments[i], b);
}

double largest_step_mv(const fit::BiasModel& m) {
  double worst = 0.0;
  if (const auto* pw = m.as_piecewise()) {
    for (std::size_t i = 0; i < pw->breakpoints_c.size(); ++i) worst = std::max(worst, std::fabs(breakpoint_step_mv(*pw, i)));
  }
  return worst;
}

ordered_json candidates_json(const std::vector<fit::Candidate>& candidates, double s) {
  ordered_json list = ordered_json::array();
  for (const auto& c : candidates) {
    list.push_back({{"name", c.name},
                    {"dof", c.score.dof},
                    {"loo_rms_dps", std::sqrt(c.score.mse) / s},
                    {"loo_max_abs_dps", c.loo_max_abs / s},
                    {"loo_mse_se_dps2", c.score.se / (s * s)},
                    {"within_one_se", c.within_one_se},
                    {"chosen", c.chosen}});
  }
  return list;
}

void print_candidates(const std::vector<fit::Candidate>& candidates, double s) {
  if (candidates.empty()) return;
  std::printf("candidates (LOO, deg/s; * within one standard error of the best, > chosen):\n");
  std::printf("  %-10s %7s %9s %9s %12s\n", "candidate", "dof", "loo_rms", "loo_max", "mse_se");
  for (const auto& c : candidates) {
    std::printf("%c%c%-10s %7.2f %9.4f %9.4f %12.3g\n", c.chosen ? '>' : ' ', c.within_one_se ? '*' : ' ',
                c.name.c_str(), c.score.dof, std::sqrt(c.score.mse) / s, c.loo_max_abs / s, c.score.se / (s * s));
  }
}

void print_model_text(const fit::BiasModel& m) {
  auto poly = [](const fit::Polynomial& p, const char* indent) {
    std::printf("%sT in [%g, %g] C: center_c %g, scale_c %g, coefficients_mv %s\n", indent, p.t_min_c,
                p.t_max_c, p.center_c, p.scale_c, numbers_text(p.coefficients_mv).c_str());
  };
  if (const auto* p = m.as_polynomial()) {
    std::printf("model: polynomial\n");
    poly(*p, "  ");
  } else if (const auto* pw = m.as_piecewise()) {
    std::printf("model: piecewise, breakpoints_c %s\n", numbers_text(pw->breakpoints_c).c_str());
    for (const auto& s : pw->segments) poly(s, "  ");
    // Independent segments step at the breakpoints: show each step.
    for (std::size_t i = 0; i < pw->breakpoints_c.size(); ++i) {
      std::printf("  step at %g C: %+.3f mV\n", pw->breakpoints_c[i], breakpoint_step_mv(*pw, i));
    }
  } else if (const auto* sp = m.as_spline()) {
    std::printf("model: cubic spline, %zu knots %g .. %g C, continuous with its first two derivatives "
                "(--json or --out for the values)\n",
                sp->knots_c.size(), sp->knots_c.front(), sp->knots_c.back());
  } else if (const auto* net = m.as_bp_network()) {
    std::printf("model: bp_network, %zu weights and biases (--json or --out for the values)\n",
                m.parameter_count());
    (void)net;
  }
}

// The calibration's own bound on its error (issue 73), in deg/s: the whole
// choice refitted to the record's noise redrawn (calibrate/calibration_bound.hpp).
// None (and why_not says why) with --no-bound, for a BP network, whose 200
// trainings would take a quarter of an hour, and for a table whose model
// passes through every point, which leaves no residual to redraw.
std::optional<CalibrationErrorBound> error_bound(const FitOptions& o, const Points& p, const fit::MethodFit& f,
                                                 const fit::MethodOptions& mo, std::string& why_not) {
  if (!o.bound) {
    why_not = "--no-bound";
    return std::nullopt;
  }
  if (f.method == fit::Method::bp_network) {
    why_not = "a BP network's refits would take too long";
    return std::nullopt;
  }
  if (p.samples == 0 && !(static_cast<double>(p.temp_c.size()) > f.dof + 1.0)) {
    why_not = "the model passes through every point of the table: no residual tells the points' noise";
    return std::nullopt;
  }
  calibrate::BoundOptions bo;
  bo.replicates = o.bound_replicates;
  bo.seed = o.seed;
  bo.bin_width_c = o.bin_width_c;
  Progress progress("the calibration's error bound: refitting the record's noise redrawn");
  bo.progress = [&progress](int done, int of) { progress.update(static_cast<double>(done) / of); };
  calibrate::CalibrationBound b;
  std::string pilot_name = "the calibration itself";
  try {
    // The replicates' truth (calibrate/calibration_bound.hpp): a recording's the choice's best
    // candidate, undersmoothed; a table's the best candidate as it is (a few dozen points: the
    // residuals' inflation for a pilot near them in parameters outgrows what it would carry), or
    // the calibration itself where that passes through every point.
    const bool table = p.samples == 0;
    fit::MethodFit pilot = table ? (f.candidates.empty() ? f : fit::fit_method(p.temp_c, p.gyro_mv,
                                                                                 calibrate::pilot_options(f, mo)))
                                 : calibrate::fit_pilot(p.temp_c, p.gyro_mv, f, mo);
    if (table && !(static_cast<double>(p.temp_c.size()) > 2.0 * pilot.dof)) pilot = f;
    if (pilot.dof != f.dof || pilot.method != f.method) {
      pilot_name = std::string(fit::method_name(pilot.method)) + " (" + pilot.structure +
                   (table ? "; the choice's best candidate)"
                          : "; the choice's best candidate, a smoothing spline with twice its parameters)");
    }
    b = p.samples > 0 ? calibrate::recording_bound(p.time_s, p.sensor_c, p.series_gyro_mv, o.die_lag_s,
                                                   o.die_lag_s_std, pilot.model, mo, bo)
                      : calibrate::table_bound(p.temp_c, p.gyro_mv, pilot.dof, pilot.model, mo, bo);
  } catch (const std::invalid_argument& e) {
    throw InputError(o.data + ": the calibration's error bound: " + e.what() +
                     " (--no-bound writes the calibration without one)");
  }
  progress.finish();
  const double s = o.scale_mv_per_dps;
  CalibrationErrorBound out;
  out.confidence = b.confidence;
  out.range_dps = std::ceil(b.range_bound_mv / s * 1e5) / 1e5;
  // Rounded for the file: a hundredth of a degree, the bound up to a hundred-thousandth of a deg/s.
  for (double t : b.temp_c) out.temp_c.push_back(std::round(t * 100.0) / 100.0);
  for (double mv : b.bound_mv) out.dps.push_back(std::ceil(mv / s * 1e5) / 1e5);
  out.how = b.how + "; the refits' truth: " + pilot_name;
  if (b.failed > 0) out.how += "; " + std::to_string(b.failed) + " replicates the method could not fit left out";
  return out;
}

std::string bound_line(const CalibrationErrorBound& b) {
  const auto [lo, hi] = std::minmax_element(b.dps.begin(), b.dps.end());
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "calibration error <= %.4f deg/s (%.0f %%) over %.1f .. %.1f C; at one temperature %.4f .. %.4f deg/s",
                b.range_dps, 100.0 * b.confidence, b.lo_c(), b.hi_c(), *lo, *hi);
  return buf;
}

ordered_json bound_json(const CalibrationErrorBound& b) {
  return ordered_json{{"confidence", b.confidence}, {"range_dps", b.range_dps}, {"range_c", {b.lo_c(), b.hi_c()}},
                      {"how", b.how},           {"c", b.temp_c},           {"dps", b.dps}};
}

// The calibration report: the points and the model, and below them each
// point's held-out residual (every choice repeated without it), so an
// engineer sees where in temperature the model is trusted and by how much.
void write_fit_plot(const FitOptions& o, const Points& p, const fit::MethodFit& f, const std::vector<double>& held_out,
                    const std::optional<CalibrationErrorBound>& bound) {
  const double s = o.scale_mv_per_dps;
  const auto [lo, hi] = std::minmax_element(p.temp_c.begin(), p.temp_c.end());
  plot::Figure fig;
  fig.title = "gyrotc fit " + std::filesystem::path(o.data).filename().string() + " (--method " + o.method + ")";
  char x_title[96] = "temperature (C)";
  if (o.die_lag_s > 0.0) {
    std::snprintf(x_title, sizeof x_title, "die temperature (C): the sensor through a %.1f s lag", o.die_lag_s);
  }
  fig.x.title = x_title;
  fig.x.tight = true;
  fig.legend_width_px = 260.0;
  fig.width_px = 1000.0;
  fig.panel_height_px = 300.0;
  plot::Panel values;
  values.y.title = "zero-rate output (mV)";
  char label[160];
  std::snprintf(label, sizeof label, "model: %s, %.1f parameters", std::string(fit::method_name(f.method)).c_str(),
                f.dof);
  plot::Series model{label, {}, {}, "#1f77b4"};
  const int steps = 600;
  for (int i = 0; i <= steps; ++i) {
    const double t = *lo + (*hi - *lo) * i / steps;
    model.x.push_back(t);
    model.y.push_back(f.model.bias_mv(t));
  }
  if (p.samples == 0) {
    std::snprintf(label, sizeof label, "%zu points of the table", p.temp_c.size());
  } else {
    std::snprintf(label, sizeof label, "%zu bins (%g C) of %zu samples", p.temp_c.size(), o.bin_width_c, p.samples);
  }
  plot::Series points{label, p.temp_c, p.gyro_mv, "#888888"};
  points.markers = true;
  model.width_px = 1.8;
  values.series = {points, model};  // the model over the points: dense bins would hide it
  plot::Series held{"", p.temp_c, {}, "#d62728"};
  plot::Panel residual;
  residual.series = {plot::Series{"", {*lo, *hi}, {0.0, 0.0}, "#888888", true}};
  if (bound) {
    // The band the true curve lies in at each temperature, beside the held-out residuals.
    std::snprintf(label, sizeof label, "%.0f %% bound (all at once %.4f deg/s)", 100.0 * bound->confidence,
                  bound->range_dps);
    plot::Series upper{label, bound->temp_c, bound->dps, "#9467bd", true};
    plot::Series lower{"", bound->temp_c, {}, "#9467bd", true};
    for (double dps : bound->dps) lower.y.push_back(-dps);
    residual.series.push_back(upper);
    residual.series.push_back(lower);
  }
  residual.y.title = "held-out residual (deg/s)";
  std::vector<double> dps;
  for (double r : held_out) dps.push_back(r / s);
  std::snprintf(label, sizeof label, "nested LOO max %.3f, rms %.3f deg/s", stats::max_abs(held_out) / s,
                stats::rms(held_out) / s);
  held.label = label;
  held.y = dps;
  held.markers = true;
  residual.series.push_back(held);
  fig.panels = {values, residual};
  plot::write_svg(fig, o.plot);
}

void run_single(const FitOptions& o) {
  if (!o.out.empty()) prepare_output_file(o.out, "--out");
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  const auto method = fit::parse_method(o.method);
  if (!method) {
    throw InputError("--method: expected poly, piecewise, spline, smooth, bpnn, paper or auto, got '" + o.method + "'");
  }
  const Points p = read_points(o);
  const fit::MethodOptions mo = method_options(o, *method, p);
  Progress progress(o.nested ? "fitting, then nested leave-one-out" : "fitting");
  const fit::MethodFit f = run_fit(p, mo, o.data);
  progress.update(0.5);
  // Without a choice the nested LOO is the plain LOO: no second pass.
  std::vector<double> nested;
  if ((o.nested || !o.plot.empty()) && fit::method_chooses(mo)) nested = run_nested(p, mo, o.data);
  // The plot's residuals are held out also when nothing was chosen (then
  // nested LOO is the plain LOO).
  progress.finish();
  std::string no_bound;
  const std::optional<CalibrationErrorBound> bound = error_bound(o, p, f, mo, no_bound);
  if (!o.plot.empty()) write_fit_plot(o, p, f, nested.empty() ? run_nested(p, mo, o.data) : nested, bound);
  const double s = o.scale_mv_per_dps;
  std::optional<double> nested_max;
  std::optional<double> nested_rms;
  if (o.nested) {
    nested_max = nested.empty() ? f.errors.loo_max_abs / s : stats::max_abs(nested) / s;
    nested_rms = nested.empty() ? f.errors.loo_rms / s : stats::rms(nested) / s;
  }
  const auto [lo, hi] = std::minmax_element(p.temp_c.begin(), p.temp_c.end());
  if (!o.out.empty()) {
    CalibrationSource src{o.data,
                          o.method,
                          f.structure,
                          p.temp_c.size(),
                          f.errors.in_sample_max_abs / s,
                          f.errors.in_sample_rms / s,
                          f.errors.loo_max_abs / s,
                          f.errors.loo_rms / s,
                          nested_max,
                          nested_rms,
                          p.accepted};
    save_calibration(f.model, o.out, s, src, o.die_lag_s, bound);
  }
  if (o.json) {
    ordered_json j{{"method", o.method},
                   {"fitted", fit::method_name(f.method)},
                   {"structure", f.structure},
                   {"choice", f.choice},
                   {"data", o.data},
                   {"input", p.kind},
                   {"points", p.temp_c.size()},
                   {"range_c", {*lo, *hi}},
                   {"scale_mv_per_dps", s},
                   {"cv_block_c", mo.cv_block_c},
                   {"die_lag_s", o.die_lag_s}};
    if (nested_max) {
      j["nested_loo_max_abs_dps"] = *nested_max;
      j["nested_loo_rms_dps"] = *nested_rms;
    }
    j["loo_max_abs_dps"] = f.errors.loo_max_abs / s;
    j["loo_rms_dps"] = f.errors.loo_rms / s;
    j["in_sample_max_abs_dps"] = f.errors.in_sample_max_abs / s;
    j["in_sample_rms_dps"] = f.errors.in_sample_rms / s;
    j["dof"] = f.dof;
    j["condition_number"] = f.condition_number;
    j["largest_breakpoint_step_mv"] = largest_step_mv(f.model);
    if (!f.candidates.empty()) j["candidates"] = candidates_json(f.candidates, s);
    j["bound"] = bound ? bound_json(*bound) : ordered_json(nullptr);
    j["model"] = model_json(f.model);
    if (!o.out.empty()) j["out"] = o.out;
    if (!o.plot.empty()) j["plot"] = o.plot;
    j.update(o.extra_json);
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("method: %s -> %s (%s)\n", o.method.c_str(), std::string(fit::method_name(f.method)).c_str(),
              f.structure.c_str());
  if (!f.choice.empty()) std::printf("choice: %s\n", f.choice.c_str());
  std::printf("points: %zu (%s, %g .. %g C), scale %g mV/(deg/s)\n", p.temp_c.size(), p.kind.c_str(), *lo, *hi, s);
  if (bound) {
    std::printf("bound: %s (%s)\n", bound_line(*bound).c_str(), bound->how.c_str());
  } else {
    std::printf("bound: none (%s)\n", no_bound.c_str());
  }
  if (nested_max) {
    std::printf("held-out error, nested LOO (every choice repeated without the point):\n");
    std::printf("nested_loo_max_abs_dps: %.4f\n", *nested_max);
    std::printf("nested_loo_rms_dps: %.4f\n", *nested_rms);
  }
  std::printf("loo_max_abs_dps: %.4f\n", f.errors.loo_max_abs / s);
  std::printf("loo_rms_dps: %.4f\n", f.errors.loo_rms / s);
  std::printf("in_sample_max_abs_dps: %.4f\n", f.errors.in_sample_max_abs / s);
  std::printf("in_sample_rms_dps: %.4f\n", f.errors.in_sample_rms / s);
  std::printf("effective_parameters: %.2f\n", f.dof);
  if (f.condition_number > 0.0) std::printf("condition_number: %.4g\n", f.condition_number);
  std::printf("stored_numbers: %zu\n", f.model.parameter_count());
  print_candidates(f.candidates, s);
  print_model_text(f.model);
  if (!o.out.empty()) std::printf("wrote %s\n", o.out.c_str());
  if (!o.plot.empty()) std::printf("wrote %s\n", o.plot.c_str());
}

void run_compare(const FitOptions& o) {
  const Points p = read_points(o);
  const double s = o.scale_mv_per_dps;
  struct Row {
    std::string name;
    std::string structure;
    double dof;
    fit::FitErrors errors;
    bool has_loo;
    double nested_max = NAN;
    double nested_rms = NAN;
    double ns;
    std::string not_fitted;  // why the data cannot take the method; empty when it was fitted
  };
  std::vector<Row> rows;
  {
    // The seed's printed coefficients (with the erratum): fitted by the seed's
    // authors to these points, so there is no held-out figure.
    const fit::BiasModel ref = fit::BiasModel::paper_reference();
    const std::vector<double> r = fit::residuals(ref, p.temp_c, p.gyro_mv);
    rows.push_back({"paper_printed", "seed's printed coefficients, erratum applied",
                    static_cast<double>(ref.parameter_count()), fit::fit_errors(r, r), false, NAN, NAN,
                    ns_per_sample(ref, s), ""});
  }
  const fit::Method methods[] = {fit::Method::paper,     fit::Method::polynomial, fit::Method::piecewise,
                                 fit::Method::spline,    fit::Method::smoothing,  fit::Method::bp_network,
                                 fit::Method::automatic};
  Progress progress(o.nested ? "fitting every method, with nested leave-one-out" : "fitting every method");
  std::size_t done = 0;
  std::vector<fit::Candidate> auto_candidates;
  for (fit::Method m : methods) {
    fit::MethodOptions mo = method_options(o, m, p);
    if (m != fit::Method::piecewise) mo.breakpoints_c.clear();
    if (m != fit::Method::piecewise && m != fit::Method::polynomial) mo.orders.clear();
    if (m == fit::Method::polynomial && mo.orders.size() > 1) mo.orders.clear();
    // A method the data cannot take (the seed's breakpoints outside a
    // sweep's range, too few points for a network) is listed with the
    // reason; the others are still compared.
    std::optional<fit::MethodFit> fitted;
    try {
      fitted = run_fit(p, mo, o.data);
    } catch (const InputError& e) {
      const std::string why = e.what();
      const std::string prefix = o.data + ": ";
      rows.push_back({std::string(fit::method_name(m)), "", NAN, fit::FitErrors{NAN, NAN, NAN, NAN}, false, NAN, NAN,
                      NAN, why.rfind(prefix, 0) == 0 ? why.substr(prefix.size()) : why});
      progress.update(static_cast<double>(++done) / std::size(methods));
      continue;
    }
    const fit::MethodFit& f = *fitted;
    Row row{std::string(fit::method_name(m)), f.structure, f.dof, f.errors, true, NAN, NAN, ns_per_sample(f.model, s), ""};
    if (o.nested) {
      if (fit::method_chooses(mo)) {
        const std::vector<double> nested = run_nested(p, mo, o.data);
        row.nested_max = stats::max_abs(nested);
        row.nested_rms = stats::rms(nested);
      } else {
        row.nested_max = f.errors.loo_max_abs;
        row.nested_rms = f.errors.loo_rms;
      }
    }
    if (m == fit::Method::automatic) auto_candidates = f.candidates;
    rows.push_back(std::move(row));
    progress.update(static_cast<double>(++done) / std::size(methods));
  }
  progress.finish();
  // rows[0] is the seed's printed model, which is evaluated, not fitted.
  if (std::all_of(rows.begin() + 1, rows.end(), [](const Row& r) { return !r.not_fitted.empty(); })) {
    throw InputError(o.data + ": no method could be fitted; the first: " + rows[1].not_fitted);
  }
  const auto structure = [](const Row& r) { return r.not_fitted.empty() ? r.structure : "not fitted: " + r.not_fitted; };
  if (o.json) {
    ordered_json list = ordered_json::array();
    for (const Row& r : rows) {
      auto number = [](double v) { return std::isnan(v) ? ordered_json(nullptr) : ordered_json(v); };
      ordered_json j{{"method", r.name}, {"structure", structure(r)}, {"dof", number(r.dof)}};
      if (o.nested) {
        j["nested_loo_max_abs_dps"] = number(r.nested_max / s);
        j["nested_loo_rms_dps"] = number(r.nested_rms / s);
      }
      j["loo_max_abs_dps"] = r.has_loo ? ordered_json(r.errors.loo_max_abs / s) : ordered_json(nullptr);
      j["loo_rms_dps"] = r.has_loo ? ordered_json(r.errors.loo_rms / s) : ordered_json(nullptr);
      j["in_sample_max_abs_dps"] = number(r.errors.in_sample_max_abs / s);
      j["in_sample_rms_dps"] = number(r.errors.in_sample_rms / s);
      j["ns_per_sample"] = number(r.ns);
      list.push_back(j);
    }
    ordered_json out{{"data", o.data},     {"input", p.kind},       {"points", p.temp_c.size()},
                     {"scale_mv_per_dps", s}, {"methods", list}, {"auto_candidates", candidates_json(auto_candidates, s)}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("%zu points (%s), errors in deg/s (scale %g mV/(deg/s)); nested LOO is the held-out error\n"
              "(every choice repeated without the point), LOO refits the chosen structure\n",
              p.temp_c.size(), p.kind.c_str(), s);
  std::printf("%-14s %6s", "method", "dof");
  if (o.nested) std::printf(" %10s %10s", "nested_max", "nested_rms");
  std::printf(" %9s %9s %9s %9s %9s  %s\n", "loo_max", "loo_rms", "in_max", "in_rms", "ns/sample", "structure");
  auto cell = [](bool have, double v) {
    char buf[16];
    if (have) std::snprintf(buf, sizeof buf, "%.3f", v);
    else std::snprintf(buf, sizeof buf, "-");
    return std::string(buf);
  };
  for (const Row& r : rows) {
    if (!r.not_fitted.empty()) {
      std::printf("%-14s %6s  %s\n", r.name.c_str(), "-", structure(r).c_str());
      continue;
    }
    std::printf("%-14s %6.1f", r.name.c_str(), r.dof);
    if (o.nested) {
      std::printf(" %10s %10s", cell(!std::isnan(r.nested_max), r.nested_max / s).c_str(),
                  cell(!std::isnan(r.nested_rms), r.nested_rms / s).c_str());
    }
    std::printf(" %9s %9s %9.3f %9.3f %9.1f  %s\n", cell(r.has_loo, r.errors.loo_max_abs / s).c_str(),
                cell(r.has_loo, r.errors.loo_rms / s).c_str(), r.errors.in_sample_max_abs / s,
                r.errors.in_sample_rms / s, r.ns, r.structure.c_str());
  }
  std::printf("auto's ");
  print_candidates(auto_candidates, s);
}

template <typename T>
void require_positive(const T& values, const char* option) {
  for (auto v : values) {
    if (!(v > 0)) throw InputError(std::string(option) + ": values must be positive");
  }
}

}  // namespace

void fit_record_auto(const std::string& data, double die_lag_s, double die_lag_s_std, const std::string& out,
                     const std::string& plot, bool json, const nlohmann::json& extra_json) {
  FitOptions o;
  o.die_lag_s = die_lag_s;
  o.die_lag_s_std = die_lag_s_std;
  o.extra_json = extra_json;
  o.data = data;
  o.method = "auto";
  o.out = out;
  o.plot = plot;
  o.json = json;
  run_single(o);
}

void add_fit_command(CLI::App& app) {
  auto opts = std::make_shared<FitOptions>();
  CLI::App* cmd = app.add_subcommand(
      "fit",
      "Fit the gyro's zero-bias temperature model (seed Section 4) to a chamber run and write the\n"
      "calibration file. Errors are in deg/s. The headline is the nested leave-one-out error: each\n"
      "point predicted by a model whose every choice was made without it; LOO refits the chosen\n"
      "structure without each point (optimistic when the structure was chosen by CV).");
  cmd->add_option("--data", opts->data,
                  "CSV: temp_c,gyro_mv[,bias_dps] (one row per temperature, like data/table2_zero_bias.csv)\n"
                  "or a recording time_s,sensor_c,gyro_mv (averaged in temperature bins)")
      ->required();
  cmd->add_option("--method", opts->method,
                  "poly | piecewise | spline (interpolating, not-a-knot) | smooth (penalised spline) |\n"
                  "bpnn | paper (seed's breakpoints -20/50 C, orders 4/3/4, independent segments) |\n"
                  "auto (polynomials, spline and smooth compared by LOO, one-standard-error rule)")
      ->capture_default_str();
  cmd->add_option("--order", opts->orders,
                  "Polynomial order; for piecewise one order for all segments or one per segment\n"
                  "(default: chosen by LOO, at most one coefficient per 3 points)")
      ->delimiter(',');
  cmd->add_option("--breakpoints", opts->breakpoints_c,
                  "Piecewise breakpoints in C, e.g. -20,50 (default: chosen by LOO, up to 3 segments of\n"
                  "at least order + 3 points)")
      ->delimiter(',');
  cmd->add_option("--continuity", opts->continuity,
                  "Piecewise: how segments meet: value (equal values at breakpoints), slope (values\n"
                  "and slopes) or none (independent segments that step, as the seed fitted them)")
      ->capture_default_str();
  cmd->add_option("--criterion", opts->criterion,
                  "smooth (and auto's smooth candidate): choose the smoothing by loo (exact\n"
                  "leave-one-out) or gcv (generalised cross-validation)")
      ->capture_default_str();
  cmd->add_option("--cv-block", opts->cv_block_c,
                  "Held out with each point when choosing: every point within this many C of it\n"
                  "(h-block cross-validation; 0: leave one out). Default: 2 bin widths for a time series,\n"
                  "whose neighbouring bins share the gyro's correlated noise; 0 for a table");
  cmd->add_option("--penalty", opts->penalty,
                  "smooth: penalise jumps (of the third derivative: shrinks towards a cubic, keeps\n"
                  "the curvature at the range ends) or curvature (classical natural smoothing spline)")
      ->capture_default_str();
  cmd->add_option("--dof", opts->dof, "smooth: effective parameters to fit instead of choosing the smoothing");
  cmd->add_option("--out", opts->out, "Write the calibration file (TOML) the controller loads");
  cmd->add_option("--plot", opts->plot,
                  "Write the calibration report (SVG): the points and the model against temperature, and\n"
                  "below them each point's held-out (nested LOO) residual in deg/s with its max and rms");
  cmd->add_flag("--json", opts->json, "Print one JSON object instead of text");
  cmd->add_flag("--compare", opts->compare,
                "Every method side by side: nested LOO, LOO and in-sample errors, effective\n"
                "parameters, ns per sample, and auto's candidates");
  cmd->add_flag("--nested,!--no-nested", opts->nested,
                "Nested LOO, the headline figure (on by default): every choice (order, breakpoints,\n"
                "smoothing, method) repeated in each fold, the honest error at an unseen temperature.\n"
                "--no-nested skips it (a piecewise search repeats a few thousand fits per fold)");
  cmd->add_option("--seed", opts->seed, "BP network: seed of initial weights and validation split")
      ->capture_default_str();
  cmd->add_option("--hidden", opts->hidden, "BP network: hidden layer sizes (seed: 10,10,10)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--restarts", opts->restarts, "BP network: trainings from different seeds, best kept")
      ->capture_default_str();
  cmd->add_option("--bin-width", opts->bin_width_c, "Time-series input: temperature bin width (C)")
      ->capture_default_str();
  cmd->add_option("--die-lag-s", opts->die_lag_s,
                  "Time-series input: bin each sample by the die's temperature, the sensor through a\n"
                  "first-order lag of this many seconds, instead of the sensor's reading (`gyrotc calibrate`\n"
                  "measures the lag from its sweep; 0: the sensor). The calibration file keeps it (die_lag_s),\n"
                  "and the unit compensates at the die's temperature estimated so")
      ->capture_default_str();
  cmd->add_option("--accept", opts->accept,
                  "Time-series input: fit despite these refusals, each a judgement call (the calibration\n"
                  "file's [source] then lists them): span (under 20 C or 8 bins, or 3 per coefficient),\n"
                  "uneven (fullest bin over 10x the median), unsettled (a bin whose samples moved one way\n"
                  "faster than 0.5 C/min on average, or crossed it faster than 2 C/min: a bin swept once up\n"
                  "and once down at one rate, as `gyrotc calibrate` does, has the die's lag cancel in its\n"
                  "mean). A record the TEC held at its setpoint is always refused")
      ->delimiter(',')
      ->check(CLI::IsMember({"span", "uneven", "unsettled"}));
  cmd->add_option("--scale", opts->scale_mv_per_dps, "Scale factor, mV/(deg/s) (seed Table 2: 8.774)")
      ->capture_default_str();
  cmd->add_flag("--bound,!--no-bound", opts->bound,
                "The calibration's own 95 % bound on its error (on by default; not for bpnn): the whole\n"
                "choice refitted to the record's noise redrawn (a recording's residuals in blocks of its\n"
                "own time order, a table's one by one); printed, in --json, in --out's [bound] and on --plot");
  cmd->add_option("--bound-replicates", opts->bound_replicates, "The bound's refits (at least 20)")
      ->capture_default_str();
  cmd->callback([opts] {
    if (!(opts->bin_width_c > 0.0)) throw InputError("--bin-width: must be positive");
    if (!(opts->die_lag_s >= 0.0 && std::isfinite(opts->die_lag_s))) {
      throw InputError("--die-lag-s: must be 0 or more seconds");
    }
    if (!(opts->scale_mv_per_dps > 0.0)) throw InputError("--scale: must be positive");
    if (opts->dof < 0.0) throw InputError("--dof: must be positive");
    if (opts->cv_block_c && !(*opts->cv_block_c >= 0.0)) throw InputError("--cv-block: must be 0 or more");
    if (opts->restarts < 1) throw InputError("--restarts: must be at least 1");
    if (opts->bound_replicates < 20) throw InputError("--bound-replicates: must be at least 20");
    require_positive(opts->hidden, "--hidden");
    if (opts->compare) {
      if (!opts->out.empty()) throw InputError("--out: not with --compare (choose one method)");
      if (!opts->plot.empty()) throw InputError("--plot: not with --compare (choose one method)");
      run_compare(*opts);
    } else {
      run_single(*opts);
    }
  });
}

}  // namespace gyrotc::app
