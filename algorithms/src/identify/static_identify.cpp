#include "gyrotc/algorithms/identify/static_identify.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "gyrotc/algorithms/identify/residual_stats.hpp"
#include "gyrotc/algorithms/identify/selection.hpp"
#include "gyrotc/algorithms/identify/separating_experiment.hpp"

namespace gyrotc::identify {
namespace {

constexpr double kKelvinOffset = 273.15;
constexpr double kGasConstantKj = 8.314462618e-3;  // kJ/(mol K)

std::vector<double> grid(double from, double to, double step) {
  std::vector<double> g;
  for (double v = from; v <= to + 1e-9; v += step) g.push_back(v);
  return g;
}



std::vector<Region> temperature_bands(std::span<const double> temp_c, const Eigen::VectorXd& residual) {
  const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
  const double width = (*hi - *lo) / 4.0;
  std::vector<Region> regions;
  for (int b = 0; b < 4; ++b) {
    Region r;
    r.start = *lo + width * b;
    r.end = b == 3 ? *hi : r.start + width;
    double sum = 0.0;
    double sum2 = 0.0;
    for (std::size_t i = 0; i < temp_c.size(); ++i) {
      const bool inside = temp_c[i] >= r.start && (b == 3 ? temp_c[i] <= r.end : temp_c[i] < r.end);
      if (!inside) continue;
      ++r.samples;
      const double v = residual(static_cast<Eigen::Index>(i));
      sum += v;
      sum2 += v * v;
    }
    if (r.samples == 0) continue;
    r.mean = sum / static_cast<double>(r.samples);
    r.rms = std::sqrt(sum2 / static_cast<double>(r.samples));
    char name[64];
    std::snprintf(name, sizeof name, "band %.4g..%.4g C", r.start, r.end);
    r.name = name;
    regions.push_back(r);
  }
  std::sort(regions.begin(), regions.end(), [](const Region& a, const Region& b) { return a.rms > b.rms; });
  return regions;
}

SelectionProblem quality_problem(std::span<const double> temp_c, const Eigen::VectorXd& y) {
  const std::size_t n = temp_c.size();
  Eigen::VectorXd kelvin(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) kelvin(static_cast<Eigen::Index>(i)) = temp_c[i] + kKelvinOffset;
  const double t_ref = kelvin.mean();

  SelectionProblem problem;
  problem.y = y;
  problem.candidates = {"gas_desorption", "parallel_loss"};
  problem.probes = {"shape_structure"};
  problem.refit_theta_in_cv = true;
  problem.build = [kelvin, t_ref](const std::vector<std::string>& effects) {
    SeparableModel m;
    std::vector<std::vector<double>> axes;
    const bool probe = std::find(effects.begin(), effects.end(), "shape_structure") != effects.end();
    for (const auto& e : effects) {
      if (e == "shape_structure") continue;
      if (e == "gas_desorption") {
        // theta: ln(desorbed fraction at t_ref), Ea in kJ/mol.
        m.theta_lower.insert(m.theta_lower.end(), {-12.0, 1.0});
        m.theta_upper.insert(m.theta_upper.end(), {8.0, 200.0});
        axes.push_back(grid(-6.0, 4.0, 1.0));
        axes.push_back(grid(5.0, 150.0, 10.0));
      } else {
        // theta: v = Q_gas-scale / q0 at t_ref (q0 = c / (v sqrt(t_ref))).
        m.theta_lower.push_back(-0.5);
        m.theta_upper.push_back(50.0);
        axes.push_back({-0.3, -0.1, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0});
      }
    }
    m.theta_grid = grid_product(axes);
    m.evaluate = [kelvin, t_ref, effects, probe](const std::vector<double>& theta, Eigen::MatrixXd& design,
                                                 Eigen::VectorXd& offset) {
      const Eigen::Index n_rows = kelvin.size();
      design = Eigen::MatrixXd::Ones(n_rows, probe ? 3 : 1);
      if (probe) {
        // A generic change of shape of ln Q: linear and quadratic in T.
        const double span = std::max(kelvin.maxCoeff() - kelvin.minCoeff(), 1e-9);
        const Eigen::ArrayXd x = (kelvin.array() - t_ref) / span;
        design.col(1) = x.matrix();
        design.col(2) = x.square().matrix();
      }
      offset = -0.5 * kelvin.array().log();
      Eigen::VectorXd gas = Eigen::VectorXd::Zero(n_rows);
      std::size_t k = 0;
      for (const auto& e : effects) {
        if (e == "shape_structure") continue;
        if (e == "gas_desorption") {
          const double lb = theta[k];
          const double ea = theta[k + 1];
          k += 2;
          for (Eigen::Index i = 0; i < n_rows; ++i) {
            gas(i) = std::exp(lb - ea / kGasConstantKj * (1.0 / kelvin(i) - 1.0 / t_ref));
            offset(i) -= std::log1p(gas(i));
          }
        }
      }
      k = 0;
      for (const auto& e : effects) {
        if (e == "shape_structure") continue;
        if (e == "gas_desorption") {
          k += 2;
        } else {
          const double v = theta[k++];
          for (Eigen::Index i = 0; i < n_rows; ++i) {
            const double term = v / (std::sqrt(kelvin(i) / t_ref) * (1.0 + gas(i)));
            offset(i) -= term > -0.999 ? std::log1p(term) : 1e3;
          }
        }
      }
    };
    return m;
  };
  const double t_min = kelvin.minCoeff();
  const double t_max = kelvin.maxCoeff();
  problem.readout = [t_ref, t_min, t_max](const std::string& effect, const std::vector<std::string>& effects,
                            const SeparableFit& fit, const Eigen::MatrixXd& cov) {
    Eigen::Index k = 1;  // theta follows the single linear parameter ln c
    for (const auto& e : effects) {
      if (e == effect) break;
      k += e == "gas_desorption" ? 2 : 1;
    }
    EffectReadout out;
    const auto t = static_cast<std::size_t>(k - 1);
    if (effect == "gas_desorption") {
      const double lb = fit.theta[t];
      const double ea = fit.theta[t + 1];
      const double d = 1.0 / (kGasConstantKj * t_ref);
      const double ln_a = lb + ea * d;
      const double var_ln_a = cov(k, k) + d * d * cov(k + 1, k + 1) + 2.0 * d * cov(k, k + 1);
      const double a = std::exp(ln_a);
      out.params = {{"a", a, a * std::sqrt(std::max(0.0, var_ln_a))},
                    {"ea_kj_per_mol", ea, standard_error(cov, k + 1)}};
      // The effect's size: how much desorbed gas changes ln Q across the
      // table, with its standard error by the delta method.
      const auto swing = [&](double lb_, double ea_) {
        const auto g = [&](double t_k) {
          return std::log1p(std::exp(lb_ - ea_ / kGasConstantKj * (1.0 / t_k - 1.0 / t_ref)));
        };
        return g(t_max) - g(t_min);
      };
      const double amplitude = swing(lb, ea);
      const double h_lb = 1e-6;
      const double h_ea = 1e-6 * std::max(1.0, ea);
      const double d_lb = (swing(lb + h_lb, ea) - amplitude) / h_lb;
      const double d_ea = (swing(lb, ea + h_ea) - amplitude) / h_ea;
      const double var_amp = d_lb * d_lb * cov(k, k) + d_ea * d_ea * cov(k + 1, k + 1) +
                             2.0 * d_lb * d_ea * cov(k, k + 1);
      // The amplitude is what must stand out of the noise; with a small
      // desorbed fraction a and Ea trade off (a exp(-Ea/RT) is what the table
      // sees), so Ea is reported with its error but not required to be sharp.
      const double se_amp = std::sqrt(std::max(0.0, var_amp));
      out.t_ratio = se_amp > 0 ? std::fabs(amplitude) / se_amp : 1e9;
      out.in_bounds = ea >= 1.0 && ea <= 200.0 && std::isfinite(a);
    } else {
      const double v = fit.theta[t];
      const double lc = fit.beta(0);
      const double q0 = v > 0 ? std::exp(lc) / (v * std::sqrt(t_ref)) : 0.0;
      const double var_ln_q0 = cov(0, 0) + cov(k, k) / (v * v) - 2.0 * cov(0, k) / v;
      out.params = {{"q0", q0, std::fabs(q0) * std::sqrt(std::max(0.0, var_ln_q0))}};
      const double se_v = standard_error(cov, k);
      out.t_ratio = se_v > 0 ? std::fabs(v) / se_v : 1e9;
      out.in_bounds = v > 0.0;
    }
    return out;
  };
  return problem;
}

SelectionProblem frequency_problem(std::span<const double> temp_c, const Eigen::VectorXd& y) {
  const std::size_t n = temp_c.size();
  Eigen::VectorXd dt(static_cast<Eigen::Index>(n));
  double mean_t = 0.0;
  for (double t : temp_c) mean_t += t;
  mean_t /= static_cast<double>(n);
  for (std::size_t i = 0; i < n; ++i) dt(static_cast<Eigen::Index>(i)) = temp_c[i] - mean_t;

  SelectionProblem problem;
  problem.y = y;
  problem.candidates = {"quadratic_tc"};
  // A generic change of shape: cubic (and quadratic, when quadratic_tc is
  // not in the model) in T.
  problem.probes = {"shape_structure"};
  problem.refit_theta_in_cv = true;
  problem.build = [dt](const std::vector<std::string>& effects) {
    const auto has = [&](const char* e) { return std::find(effects.begin(), effects.end(), e) != effects.end(); };
    SeparableModel m;
    m.evaluate = [dt, quadratic = has("quadratic_tc"), probe = has("shape_structure")](
                     const std::vector<double>&, Eigen::MatrixXd& design, Eigen::VectorXd& offset) {
      const double span = std::max(dt.cwiseAbs().maxCoeff(), 1e-9);
      std::vector<Eigen::VectorXd> columns{Eigen::VectorXd::Ones(dt.size()), dt};
      if (quadratic || probe) columns.push_back(dt.array().square());
      if (probe) columns.push_back((dt.array() / span).cube());
      design.resize(dt.size(), static_cast<Eigen::Index>(columns.size()));
      for (std::size_t c = 0; c < columns.size(); ++c) design.col(static_cast<Eigen::Index>(c)) = columns[c];
      offset = Eigen::VectorXd::Zero(dt.size());
    };
    return m;
  };
  problem.readout = [](const std::string&, const std::vector<std::string>&, const SeparableFit& fit,
                       const Eigen::MatrixXd& cov) {
    EffectReadout out;
    const double f0 = fit.beta(0);
    const double tc2 = fit.beta(2) / f0 * 1e6;
    out.params = {{"tc2_ppm_per_c2", tc2, standard_error(cov, 2) / f0 * 1e6}};
    out.t_ratio = standard_error(cov, 2) > 0 ? std::fabs(fit.beta(2)) / standard_error(cov, 2) : 1e9;
    // Second-order coefficients of silicon resonators are a small fraction
    // of a ppm/C^2; allow an order of magnitude more.
    out.in_bounds = std::fabs(tc2) <= 5.0;
    return out;
  };
  return problem;
}

}  // namespace

Identification identify_static(std::span<const double> temp_c, std::span<const double> value,
                               StaticQuantity quantity, const std::string& target,
                               const Criteria& criteria) {
  if (temp_c.size() != value.size()) throw std::invalid_argument("temperature and value lengths differ");
  if (temp_c.size() < 6) throw std::invalid_argument("at least 6 points are needed");
  const std::size_t n = temp_c.size();
  const bool quality = quantity == StaticQuantity::quality_factor;
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    if (quality && !(value[i] > 0.0)) throw std::invalid_argument("quality factor must be positive");
    y(static_cast<Eigen::Index>(i)) = quality ? std::log(value[i]) : value[i];
  }
  SelectionProblem problem = quality ? quality_problem(temp_c, y) : frequency_problem(temp_c, y);
  // Leave-one-out: with a handful of soak points every point is a fold.
  problem.folds = static_cast<int>(n);
  problem.fold_of.resize(n);
  for (std::size_t i = 0; i < n; ++i) problem.fold_of[i] = static_cast<int>(i);

  const SelectionResult sel = select_effects(problem, criteria);

  Identification id;
  id.target = target;
  id.units = quality ? "ln(Q)" : "Hz";
  id.x_name = "temp_c";
  const Eigen::VectorXd& r0 = sel.baseline.residual;
  const Eigen::VectorXd& r1 = sel.final_fit.residual;
  const std::size_t lags = std::max<std::size_t>(1, n / 4);
  id.baseline_rms = std::sqrt(r0.squaredNorm() / static_cast<double>(n));
  id.baseline_max_abs = r0.cwiseAbs().maxCoeff();
  id.whiteness_p_before = ljung_box_p({r0.data(), n}, lags);
  if (quality) {
    id.baseline_params = {{"c", std::exp(sel.baseline.beta(0)), 0.0}};
  } else {
    const double f0 = sel.baseline.beta(0);
    const double s2 = sel.baseline.sse / std::max(1.0, static_cast<double>(n) - 2.0);
    const double se_slope = std::sqrt(std::max(0.0, sel.baseline.covariance_unscaled(1, 1) * s2));
    id.baseline_params = {{"tc1_ppm_per_c", sel.baseline.beta(1) / f0 * 1e6, se_slope / f0 * 1e6}};
  }
  id.regions = temperature_bands(temp_c, r0);
  id.added = sel.added;
  id.tried = sel.tried;
  id.verdict = sel.verdict;
  id.statement = verdict_statement(sel);
  id.unexplained = sel.unexplained;
  id.alternatives = sel.alternatives;
  {
    RecordCoverage table;
    table.low_c = *std::min_element(temp_c.begin(), temp_c.end());
    table.high_c = *std::max_element(temp_c.begin(), temp_c.end());
    for (auto& a : id.alternatives) a.experiment = separating_experiment(a.effect, a.other, table);
  }
  id.final_rms = std::sqrt(r1.squaredNorm() / static_cast<double>(n));
  id.final_max_abs = r1.cwiseAbs().maxCoeff();
  id.whiteness_p_after = ljung_box_p({r1.data(), n}, lags);
  id.shrink = id.final_rms > 0 ? id.baseline_rms / id.final_rms : 1.0;
  id.x.assign(temp_c.begin(), temp_c.end());
  id.measured.assign(value.begin(), value.end());
  for (std::size_t i = 0; i < n; ++i) {
    const auto e = static_cast<Eigen::Index>(i);
    id.baseline_model.push_back(quality ? std::exp(sel.baseline.prediction(e)) : sel.baseline.prediction(e));
    id.final_model.push_back(quality ? std::exp(sel.final_fit.prediction(e)) : sel.final_fit.prediction(e));
    id.effect_signal.push_back(sel.final_fit.prediction(e) - sel.baseline.prediction(e));
  }
  id.effect_signal_name = quality ? "added ln Q" : "added Hz";
  return id;
}

}  // namespace gyrotc::identify
