// `gyrotc fit`: turns a chamber run (Table 2-like CSV, or a time series binned
// by temperature) into a zero-bias model, reports in-sample and leave-one-out
// errors, compares the methods side by side, and writes the calibration file.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/fit/cross_validation.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc/algorithms/stats/summary.hpp"
#include "gyrotc/app/calibration_file.hpp"
#include "gyrotc/app/commands.hpp"
#include "gyrotc/app/csv_table.hpp"
#include "gyrotc/app/errors.hpp"
#include "gyrotc/app/progress.hpp"
#include "gyrotc/app/output_path.hpp"

namespace gyrotc::app {
namespace {

using nlohmann::ordered_json;

struct FitOptions {
  std::string data;
  std::string method = "auto";
  std::vector<int> orders;
  std::vector<double> breakpoints_c;
  bool continuous = false;
  std::string out;
  bool json = false;
  bool compare = false;
  bool nested = false;
  std::uint64_t seed = 1;
  std::vector<int> hidden = {10, 10, 10};
  int restarts = 3;
  double bin_width_c = 1.0;
  double scale_mv_per_dps = fit::Compensator::kSeedScaleMvPerDps;
};

struct Points {
  std::vector<double> temp_c;
  std::vector<double> gyro_mv;
  std::string kind;  // "table" or "time series (N samples, W C bins)"
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

// A recording (time_s, sensor_c, gyro_mv): averaged in temperature bins.
Points read_series(const CsvTable& table, double bin_width_c) {
  table.require_increasing("time_s");
  const std::vector<double> temp = table.numbers("sensor_c");
  const std::vector<double> gyro = table.numbers("gyro_mv");
  struct Bin {
    double temp_sum = 0.0;
    double gyro_sum = 0.0;
    std::size_t count = 0;
  };
  std::map<long long, Bin> bins;
  for (std::size_t i = 0; i < temp.size(); ++i) {
    Bin& b = bins[static_cast<long long>(std::floor(temp[i] / bin_width_c))];
    b.temp_sum += temp[i];
    b.gyro_sum += gyro[i];
    ++b.count;
  }
  Points p;
  for (const auto& [key, b] : bins) {
    p.temp_c.push_back(b.temp_sum / static_cast<double>(b.count));
    p.gyro_mv.push_back(b.gyro_sum / static_cast<double>(b.count));
  }
  char buf[96];
  std::snprintf(buf, sizeof buf, "time series, %zu samples in %g C bins", temp.size(), bin_width_c);
  p.kind = buf;
  return p;
}

Points read_points(const FitOptions& o) {
  const CsvTable table = CsvTable::read(o.data);
  if (table.has("temp_c")) return read_table(table);
  if (table.has("sensor_c")) return read_series(table, o.bin_width_c);
  std::string have;
  for (const auto& c : table.columns()) have += (have.empty() ? "" : ", ") + c;
  throw InputError(o.data + ": missing column 'temp_c' (a table with temp_c, gyro_mv) or 'sensor_c' (a "
                            "time series with time_s, sensor_c, gyro_mv); columns: " + have);
}

fit::MethodOptions method_options(const FitOptions& o, fit::Method m) {
  fit::MethodOptions mo;
  mo.method = m;
  mo.orders = o.orders;
  mo.breakpoints_c = o.breakpoints_c;
  mo.continuous = o.continuous;
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
    // Segments are fitted independently unless --continuous: show the steps.
    for (std::size_t i = 0; i < pw->breakpoints_c.size(); ++i) {
      const double b = pw->breakpoints_c[i];
      std::printf("  step at %g C: %+.3f mV\n", b,
                  fit::evaluate(pw->segments[i + 1], b) - fit::evaluate(pw->segments[i], b));
    }
  } else if (const auto* net = m.as_bp_network()) {
    std::printf("model: bp_network, %zu weights and biases (--json or --out for the values)\n",
                m.parameter_count());
    (void)net;
  }
}

void run_single(const FitOptions& o) {
  if (!o.out.empty()) prepare_output_file(o.out, "--out");
  const auto method = fit::parse_method(o.method);
  if (!method) throw InputError("--method: expected poly, piecewise, bpnn, paper or auto, got '" + o.method + "'");
  const Points p = read_points(o);
  const fit::MethodOptions mo = method_options(o, *method);
  std::unique_ptr<Progress> progress;
  if (*method == fit::Method::bp_network) progress = std::make_unique<Progress>("training BP networks");
  const fit::MethodFit f = run_fit(p, mo, o.data);
  std::vector<double> nested;
  if (o.nested) nested = run_nested(p, mo, o.data);
  if (progress) progress->finish();
  const double s = o.scale_mv_per_dps;
  const auto [lo, hi] = std::minmax_element(p.temp_c.begin(), p.temp_c.end());
  if (!o.out.empty()) {
    CalibrationSource src{o.data,
                          o.method,
                          f.structure,
                          p.temp_c.size(),
                          f.errors.in_sample_max_abs / s,
                          f.errors.in_sample_rms / s,
                          f.errors.loo_max_abs / s,
                          f.errors.loo_rms / s};
    save_calibration(f.model, o.out, s, src);
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
                   {"in_sample_max_abs_dps", f.errors.in_sample_max_abs / s},
                   {"in_sample_rms_dps", f.errors.in_sample_rms / s},
                   {"loo_max_abs_dps", f.errors.loo_max_abs / s},
                   {"loo_rms_dps", f.errors.loo_rms / s}};
    if (o.nested) {
      j["nested_loo_max_abs_dps"] = stats::max_abs(nested) / s;
      j["nested_loo_rms_dps"] = stats::rms(nested) / s;
    }
    j["condition_number"] = f.condition_number;
    j["model"] = model_json(f.model);
    if (!o.out.empty()) j["out"] = o.out;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("method: %s -> %s (%s)\n", o.method.c_str(), std::string(fit::method_name(f.method)).c_str(),
              f.structure.c_str());
  if (!f.choice.empty()) std::printf("choice: %s\n", f.choice.c_str());
  std::printf("points: %zu (%s, %g .. %g C), scale %g mV/(deg/s)\n", p.temp_c.size(), p.kind.c_str(), *lo, *hi, s);
  std::printf("in_sample_max_abs_dps: %.4f\n", f.errors.in_sample_max_abs / s);
  std::printf("in_sample_rms_dps: %.4f\n", f.errors.in_sample_rms / s);
  std::printf("loo_max_abs_dps: %.4f\n", f.errors.loo_max_abs / s);
  std::printf("loo_rms_dps: %.4f\n", f.errors.loo_rms / s);
  if (o.nested) {
    std::printf("nested_loo_max_abs_dps: %.4f\n", stats::max_abs(nested) / s);
    std::printf("nested_loo_rms_dps: %.4f\n", stats::rms(nested) / s);
  }
  if (f.condition_number > 0.0) std::printf("condition_number: %.4g\n", f.condition_number);
  std::printf("parameters: %zu\n", f.model.parameter_count());
  print_model_text(f.model);
  if (!o.out.empty()) std::printf("wrote %s\n", o.out.c_str());
}

void run_compare(const FitOptions& o) {
  const Points p = read_points(o);
  const double s = o.scale_mv_per_dps;
  struct Row {
    std::string name;
    std::string structure;
    std::size_t parameters;
    fit::FitErrors errors;
    bool has_loo;
    double nested_max = NAN;
    double nested_rms = NAN;
    double ns;
  };
  std::vector<Row> rows;
  {
    // The seed's printed coefficients (with the erratum): nothing is fitted,
    // so there is no leave-one-out figure.
    const fit::BiasModel ref = fit::BiasModel::paper_reference();
    const std::vector<double> r = fit::residuals(ref, p.temp_c, p.gyro_mv);
    rows.push_back({"paper_printed", "seed's printed coefficients, erratum applied", ref.parameter_count(),
                    fit::fit_errors(r, r), false, NAN, NAN, ns_per_sample(ref, s)});
  }
  const fit::Method methods[] = {fit::Method::paper, fit::Method::polynomial, fit::Method::piecewise,
                                 fit::Method::bp_network, fit::Method::automatic};
  Progress progress("fitting every method");
  std::size_t done = 0;
  for (fit::Method m : methods) {
    fit::MethodOptions mo = method_options(o, m);
    if (m != fit::Method::piecewise) mo.breakpoints_c.clear();
    if (m == fit::Method::paper || m == fit::Method::automatic || m == fit::Method::bp_network) mo.orders.clear();
    if (m == fit::Method::polynomial && mo.orders.size() > 1) mo.orders.clear();
    const fit::MethodFit f = run_fit(p, mo, o.data);
    Row row{std::string(fit::method_name(m)), f.structure, f.model.parameter_count(), f.errors, true, NAN, NAN,
            ns_per_sample(f.model, s)};
    if (o.nested && m != fit::Method::bp_network && m != fit::Method::paper) {
      const std::vector<double> nested = run_nested(p, mo, o.data);
      row.nested_max = stats::max_abs(nested);
      row.nested_rms = stats::rms(nested);
    }
    rows.push_back(std::move(row));
    progress.update(static_cast<double>(++done) / std::size(methods));
  }
  progress.finish();
  if (o.json) {
    ordered_json list = ordered_json::array();
    for (const Row& r : rows) {
      ordered_json j{{"method", r.name},
                     {"structure", r.structure},
                     {"parameters", r.parameters},
                     {"in_sample_max_abs_dps", r.errors.in_sample_max_abs / s},
                     {"in_sample_rms_dps", r.errors.in_sample_rms / s}};
      j["loo_max_abs_dps"] = r.has_loo ? ordered_json(r.errors.loo_max_abs / s) : ordered_json(nullptr);
      j["loo_rms_dps"] = r.has_loo ? ordered_json(r.errors.loo_rms / s) : ordered_json(nullptr);
      if (o.nested) {
        j["nested_loo_max_abs_dps"] = std::isnan(r.nested_max) ? ordered_json(nullptr) : ordered_json(r.nested_max / s);
        j["nested_loo_rms_dps"] = std::isnan(r.nested_rms) ? ordered_json(nullptr) : ordered_json(r.nested_rms / s);
      }
      j["ns_per_sample"] = r.ns;
      list.push_back(j);
    }
    ordered_json out{{"data", o.data}, {"input", p.kind}, {"points", p.temp_c.size()}, {"scale_mv_per_dps", s},
                     {"methods", list}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("%zu points (%s), errors in deg/s (scale %g mV/(deg/s))\n", p.temp_c.size(), p.kind.c_str(), s);
  std::printf("%-14s %6s %9s %9s %9s %9s", "method", "params", "in_max", "in_rms", "loo_max", "loo_rms");
  if (o.nested) std::printf(" %10s %10s", "nested_max", "nested_rms");
  std::printf(" %9s  %s\n", "ns/sample", "structure");
  auto cell = [](bool have, double v) {
    char buf[16];
    if (have) std::snprintf(buf, sizeof buf, "%.3f", v);
    else std::snprintf(buf, sizeof buf, "-");
    return std::string(buf);
  };
  for (const Row& r : rows) {
    std::printf("%-14s %6zu %9.3f %9.3f %9s %9s", r.name.c_str(), r.parameters, r.errors.in_sample_max_abs / s,
                r.errors.in_sample_rms / s, cell(r.has_loo, r.errors.loo_max_abs / s).c_str(),
                cell(r.has_loo, r.errors.loo_rms / s).c_str());
    if (o.nested) {
      std::printf(" %10s %10s", cell(!std::isnan(r.nested_max), r.nested_max / s).c_str(),
                  cell(!std::isnan(r.nested_rms), r.nested_rms / s).c_str());
    }
    std::printf(" %9.1f  %s\n", r.ns, r.structure.c_str());
  }
}

template <typename T>
void require_positive(const T& values, const char* option) {
  for (auto v : values) {
    if (!(v > 0)) throw InputError(std::string(option) + ": values must be positive");
  }
}

}  // namespace

void add_fit_command(CLI::App& app) {
  auto opts = std::make_shared<FitOptions>();
  CLI::App* cmd = app.add_subcommand(
      "fit",
      "Fit the gyro's zero-bias temperature model (seed Section 4) to a chamber run and write the\n"
      "calibration file. Errors are in deg/s; LOO = leave-one-out cross-validation (each point\n"
      "predicted by the same structure fitted without it).");
  cmd->add_option("--data", opts->data,
                  "CSV: temp_c,gyro_mv[,bias_dps] (one row per temperature, like data/table2_zero_bias.csv)\n"
                  "or a recording time_s,sensor_c,gyro_mv (averaged in temperature bins)")
      ->required();
  cmd->add_option("--method", opts->method,
                  "poly | piecewise | bpnn | paper (seed's breakpoints -20/50 C, orders 4/3/4) | auto\n"
                  "(polynomial or piecewise, orders and breakpoints chosen by LOO)")
      ->capture_default_str();
  cmd->add_option("--order", opts->orders,
                  "Polynomial order; for piecewise one order for all segments or one per segment\n"
                  "(default: chosen by LOO)")
      ->delimiter(',');
  cmd->add_option("--breakpoints", opts->breakpoints_c,
                  "Piecewise breakpoints in C, e.g. -20,50 (default: chosen by LOO, up to 3 segments)")
      ->delimiter(',');
  cmd->add_flag("--continuous", opts->continuous, "Piecewise with given breakpoints: equal values at breakpoints");
  cmd->add_option("--out", opts->out, "Write the calibration file (TOML) the controller loads");
  cmd->add_flag("--json", opts->json, "Print one JSON object instead of text");
  cmd->add_flag("--compare", opts->compare,
                "Every method side by side: in-sample and LOO errors, parameters, ns per sample");
  cmd->add_flag("--nested", opts->nested,
                "Also nested LOO (the order/breakpoint/method choice repeated in every fold): the\n"
                "unbiased figure for structures chosen by CV; slow");
  cmd->add_option("--seed", opts->seed, "BP network: seed of initial weights and validation split")
      ->capture_default_str();
  cmd->add_option("--hidden", opts->hidden, "BP network: hidden layer sizes (seed: 10,10,10)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--restarts", opts->restarts, "BP network: trainings from different seeds, best kept")
      ->capture_default_str();
  cmd->add_option("--bin-width", opts->bin_width_c, "Time-series input: temperature bin width (C)")
      ->capture_default_str();
  cmd->add_option("--scale", opts->scale_mv_per_dps, "Scale factor, mV/(deg/s) (seed Table 2: 8.774)")
      ->capture_default_str();
  cmd->callback([opts] {
    if (!(opts->bin_width_c > 0.0)) throw InputError("--bin-width: must be positive");
    if (!(opts->scale_mv_per_dps > 0.0)) throw InputError("--scale: must be positive");
    if (opts->restarts < 1) throw InputError("--restarts: must be at least 1");
    require_positive(opts->hidden, "--hidden");
    if (opts->compare) {
      if (!opts->out.empty()) throw InputError("--out: not with --compare (choose one method)");
      run_compare(*opts);
    } else {
      run_single(*opts);
    }
  });
}

}  // namespace gyrotc::app
