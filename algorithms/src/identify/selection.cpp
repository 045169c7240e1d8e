#include "gyrotc/algorithms/identify/selection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <span>

#include "gyrotc/algorithms/identify/residual_stats.hpp"

namespace gyrotc::identify {
namespace {

std::span<const double> as_span(const Eigen::VectorXd& v) {
  return {v.data(), static_cast<std::size_t>(v.size())};
}

double parameter_count(const SeparableFit& fit) {
  return static_cast<double>(fit.beta.size()) + static_cast<double>(fit.theta.size());
}

bool is_series(const SelectionProblem& p) { return !p.time_s.empty(); }

SeparableModel subset_model(const SeparableModel& model, const std::vector<Eigen::Index>& rows) {
  SeparableModel sub = model;
  sub.evaluate = [model, rows](const std::vector<double>& theta, Eigen::MatrixXd& design,
                               Eigen::VectorXd& offset) {
    Eigen::MatrixXd full_design;
    Eigen::VectorXd full_offset;
    model.evaluate(theta, full_design, full_offset);
    design.resize(static_cast<Eigen::Index>(rows.size()), full_design.cols());
    offset.resize(static_cast<Eigen::Index>(rows.size()));
    for (std::size_t r = 0; r < rows.size(); ++r) {
      design.row(static_cast<Eigen::Index>(r)) = full_design.row(rows[r]);
      offset(static_cast<Eigen::Index>(r)) = full_offset(rows[r]);
    }
  };
  return sub;
}

// A model fitted and scored: theta by (unweighted) least squares, the linear
// parameters, residual and covariance under its noise model.
struct Scored {
  SeparableModel model;
  SeparableFit fit;
  WanderNoise noise;
  double log_likelihood = 0.0;
  double lrv_factor = 1.0;
  Eigen::MatrixXd covariance;  // of [beta; theta], scaled
  // Series: the whitened Jacobian [design, d/d theta] and residual.
  Eigen::MatrixXd white_jacobian;
  Eigen::VectorXd white_residual;
};

// fixed_noise: test under this noise model (the model without the candidate's)
// instead of fitting one; nullptr fits it, searching from `start` if given.
Scored score(const SelectionProblem& problem, SeparableModel model, SeparableFit fit,
             const WanderNoise* fixed_noise = nullptr, const WanderNoise* start = nullptr) {
  Scored s;
  const Eigen::Index n = problem.y.size();
  const double nd = static_cast<double>(n);
  const double dof = std::max(1.0, nd - parameter_count(fit));
  if (!is_series(problem)) {
    s.log_likelihood = -0.5 * nd * std::log(std::max(fit.sse / nd, 1e-300));
    s.covariance = fit.covariance_unscaled * (fit.sse / dof);
    s.model = std::move(model);
    s.fit = std::move(fit);
    return s;
  }
  // Noise and linear part by alternating: the noise fitted to the residual
  // by maximum likelihood, the linear part by GLS under it, until the
  // likelihood stops rising. The least-squares residual alone would
  // understate slow wander (the flexible bias curve soaks part of it up).
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  model.evaluate(fit.theta, design, offset);
  const Eigen::VectorXd data = problem.y - offset;
  GlsFit gls;
  gls.log_likelihood = -std::numeric_limits<double>::infinity();
  Eigen::VectorXd residual = fit.residual;
  for (int iter = 0; iter < (fixed_noise ? 1 : 4); ++iter) {
    WanderNoise noise = fixed_noise ? *fixed_noise
                                    : fit_wander_noise(residual, problem.time_s, problem.white_scale,
                                                       problem.wander_tau_min_s, problem.wander_tau_max_s,
                                                       iter == 0 ? start : &s.noise);
    GlsFit next = fit_gls(data, design, noise, problem.time_s, problem.white_scale);
    if (!(next.log_likelihood > gls.log_likelihood + 0.01)) break;
    // The filter uses the ratio of wander to white variance; the white
    // variance is this fit's.
    noise.wander_var *= next.white_var / noise.white_var;
    noise.white_var = next.white_var;
    s.noise = noise;
    gls = std::move(next);
    residual = data - design * gls.beta;
  }
  // Then the wander by the restricted likelihood, from that optimum: the
  // residual's maximum likelihood treats the bias curve's dozens of
  // coefficients as known and so credits it with the wander's slow power
  // (beside a 40-cell curve, a quarter of it: wander_noise_test.cpp), which
  // left slow candidates and probes judged against too little noise (a
  // 1000 s-wander null fitted 0.07 mV / 233 s, truth 0.15 mV / 1000 s, was
  // read as a drift at t = 8). It moves only within the full likelihood's
  // 95 % region: along long, large wander REML is nearly flat, and free it
  // took an unmodelled 1.5 mV warm-up for 0.44 mV / 2300 s of wander. The
  // likelihood compared between models is the full one, at each model's
  // restricted-likelihood noise.
  if (!fixed_noise) {
    WanderNoise r = refine_wander_noise_restricted(data, design, problem.time_s, problem.white_scale,
                                                   problem.wander_tau_min_s, problem.wander_tau_max_s, s.noise);
    GlsFit next = fit_gls(data, design, r, problem.time_s, problem.white_scale);
    r.wander_var *= next.white_var / r.white_var;
    r.white_var = next.white_var;
    s.noise = r;
    gls = std::move(next);
  }
  s.log_likelihood = gls.log_likelihood;
  s.lrv_factor = long_run_variance_factor(as_span(gls.white_residual));
  fit.beta = gls.beta;
  fit.prediction = offset + design * fit.beta;
  fit.residual = problem.y - fit.prediction;
  fit.sse = fit.residual.squaredNorm();
  const Whitener whitener(s.noise, problem.time_s, problem.white_scale);
  s.white_jacobian = model_jacobian(model, fit.theta, fit.beta);
  whitener.apply(s.white_jacobian);
  fit.covariance_unscaled = inverse_normal(s.white_jacobian);
  s.covariance = fit.covariance_unscaled * (gls.white_var * s.lrv_factor);
  s.white_residual = gls.white_residual;
  s.model = std::move(model);
  s.fit = std::move(fit);
  return s;
}

struct HeldOut {
  std::vector<double> fold_sse;
  std::vector<double> unit_sse;
  std::vector<double> fold_count;  // held-out samples scored per fold
  // Each sample's held-out error (the innovation on series); NaN where the
  // sample is not scored.
  Eigen::VectorXd error;
};

int unit(const SelectionProblem& p, Eigen::Index i) {
  const auto k = static_cast<std::size_t>(i);
  return p.unit_of.empty() ? p.fold_of[k] : p.unit_of[k];
}

// The samples each fold scores: its own, less (with max_held_out_leverage)
// those whose prediction from the training folds' baseline is an
// extrapolation: leverage x' (X_train' X_train)^-1 x above the limit.
std::vector<std::vector<bool>> scored_rows(const SelectionProblem& problem, const SeparableModel& baseline,
                                           const std::vector<double>& theta) {
  const Eigen::Index n = problem.y.size();
  std::vector<std::vector<bool>> out(static_cast<std::size_t>(problem.folds), std::vector<bool>(static_cast<std::size_t>(n)));
  for (Eigen::Index i = 0; i < n; ++i) {
    out[static_cast<std::size_t>(problem.fold_of[static_cast<std::size_t>(i)])][static_cast<std::size_t>(i)] = true;
  }
  if (!(problem.max_held_out_leverage > 0.0)) return out;
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  baseline.evaluate(theta, design, offset);
  const Eigen::MatrixXd normal = design.transpose() * design;
  for (int f = 0; f < problem.folds; ++f) {
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (out[static_cast<std::size_t>(f)][static_cast<std::size_t>(i)]) rows.push_back(i);
    }
    Eigen::MatrixXd held(static_cast<Eigen::Index>(rows.size()), design.cols());
    for (std::size_t r = 0; r < rows.size(); ++r) held.row(static_cast<Eigen::Index>(r)) = design.row(rows[r]);
    Eigen::MatrixXd train = normal - held.transpose() * held;
    // Columns scaled by the whole record's normal matrix, and a ridge of
    // 1e-8 of it: a basis function the training rows barely touch gets a
    // large leverage instead of a singular solve.
    Eigen::VectorXd scale(train.rows());
    for (Eigen::Index j = 0; j < train.rows(); ++j) scale(j) = normal(j, j) > 0.0 ? 1.0 / std::sqrt(normal(j, j)) : 1.0;
    train = scale.asDiagonal() * train * scale.asDiagonal();
    train.diagonal().array() += 1e-8;
    const Eigen::MatrixXd scaled_held = held * scale.asDiagonal();
    const Eigen::MatrixXd solved = train.ldlt().solve(scaled_held.transpose());
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const double leverage = scaled_held.row(static_cast<Eigen::Index>(r)).dot(solved.col(static_cast<Eigen::Index>(r)));
      if (leverage > problem.max_held_out_leverage) out[static_cast<std::size_t>(f)][static_cast<std::size_t>(rows[r])] = false;
    }
  }
  return out;
}

template <typename T>
T take(const T& v, const std::vector<Eigen::Index>& rows) {
  T out(static_cast<Eigen::Index>(rows.size()), v.cols());
  for (std::size_t r = 0; r < rows.size(); ++r) out.row(static_cast<Eigen::Index>(r)) = v.row(rows[r]);
  return out;
}

std::vector<double> take(const std::vector<double>& v, const std::vector<Eigen::Index>& rows) {
  std::vector<double> out;
  if (v.empty()) return out;
  for (Eigen::Index r : rows) out.push_back(v[static_cast<std::size_t>(r)]);
  return out;
}

// Held-out squared errors of `model` at theta, per fold and per unit.
// Series: the linear part is refitted by GLS on the training folds alone
// (their own noise filter, the held-out blocks a gap), then the residual of
// the training and scored held-out samples is run through the noise filter
// and the held-out samples' innovations are scored: one-step-ahead errors
// of model plus wander forecast, independent when the noise model holds, so
// interleaved blocks are fair even under slow wander. Tables: plain errors,
// theta refitted per fold when refit_theta_in_cv.
HeldOut held_out(const SelectionProblem& problem, const SeparableModel& model, const std::vector<double>& theta,
                 const WanderNoise* noise, const std::vector<std::vector<bool>>& scored) {
  const Eigen::Index n = problem.y.size();
  HeldOut h;
  h.fold_sse.assign(static_cast<std::size_t>(problem.folds), 0.0);
  h.fold_count.assign(static_cast<std::size_t>(problem.folds), 0.0);
  int units = 0;
  for (Eigen::Index i = 0; i < n; ++i) units = std::max(units, unit(problem, i) + 1);
  h.unit_sse.assign(static_cast<std::size_t>(units), 0.0);
  h.error = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  const auto add = [&](Eigen::Index i, int fold, double r) {
    h.error(i) = r;
    h.fold_sse[static_cast<std::size_t>(fold)] += r * r;
    h.fold_count[static_cast<std::size_t>(fold)] += 1.0;
    h.unit_sse[static_cast<std::size_t>(unit(problem, i))] += r * r;
  };
  Eigen::MatrixXd design;
  Eigen::VectorXd offset;
  if (noise != nullptr) model.evaluate(theta, design, offset);

  for (int f = 0; f < problem.folds; ++f) {
    const std::vector<bool>& score_row = scored[static_cast<std::size_t>(f)];
    std::vector<bool> train(static_cast<std::size_t>(n));
    std::vector<Eigen::Index> train_rows;
    for (Eigen::Index i = 0; i < n; ++i) {
      train[static_cast<std::size_t>(i)] = problem.fold_of[static_cast<std::size_t>(i)] != f;
      if (train[static_cast<std::size_t>(i)]) train_rows.push_back(i);
    }
    if (noise == nullptr) {
      std::vector<double> fold_theta = theta;
      if (problem.refit_theta_in_cv && !theta.empty()) {
        // LM from the full-data optimum: the fold moves it only a little.
        SeparableModel sub = subset_model(model, train_rows);
        sub.theta_grid = {theta};
        fold_theta = fit_separable(take(problem.y, train_rows), sub).theta;
      }
      const Eigen::VectorXd prediction = predict_with_theta(problem.y, model, fold_theta, train);
      for (Eigen::Index i = 0; i < n; ++i) {
        if (score_row[static_cast<std::size_t>(i)]) add(i, f, problem.y(i) - prediction(i));
      }
      continue;
    }
    const Whitener train_filter(*noise, take(problem.time_s, train_rows), take(problem.white_scale, train_rows));
    Eigen::MatrixXd train_design = take(design, train_rows);
    Eigen::VectorXd train_y = take(Eigen::VectorXd(problem.y - offset), train_rows);
    train_filter.apply(train_design);
    train_filter.apply(train_y);
    const Eigen::VectorXd beta = solve_linear(train_design, train_y);
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (train[static_cast<std::size_t>(i)] || score_row[static_cast<std::size_t>(i)]) rows.push_back(i);
    }
    Eigen::VectorXd residual = take(Eigen::VectorXd(problem.y - offset - design * beta), rows);
    const Whitener filter(*noise, take(problem.time_s, rows), take(problem.white_scale, rows));
    filter.apply(residual);
    for (std::size_t r = 0; r < rows.size(); ++r) {
      if (score_row[static_cast<std::size_t>(rows[r])]) add(rows[r], f, residual(static_cast<Eigen::Index>(r)));
    }
  }
  return h;
}

std::vector<double> fold_rms(const HeldOut& h) {
  std::vector<double> out(h.fold_sse.size());
  for (std::size_t f = 0; f < out.size(); ++f) {
    out[f] = h.fold_count[f] > 0 ? std::sqrt(h.fold_sse[f] / h.fold_count[f]) : 0.0;
  }
  return out;
}

double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd ac = a.array() - a.mean();
  const Eigen::VectorXd bc = b.array() - b.mean();
  const double denom = ac.norm() * bc.norm();
  return denom > 0.0 ? ac.dot(bc) / denom : 0.0;
}

// Whether the runner-up's held-out error is not worse than the best's by z
// standard errors of the mean paired difference over the held-out units.
bool held_out_tie(const std::vector<double>& best, const std::vector<double>& other, double z) {
  std::vector<double> d;
  for (std::size_t u = 0; u < best.size() && u < other.size(); ++u) {
    if (best[u] > 0.0 || other[u] > 0.0) d.push_back(other[u] - best[u]);
  }
  if (d.size() < 3) return true;
  double mean = 0.0;
  for (double v : d) mean += v;
  mean /= static_cast<double>(d.size());
  double var = 0.0;
  for (double v : d) var += (v - mean) * (v - mean);
  var /= static_cast<double>(d.size() - 1);
  return mean < z * std::sqrt(var / static_cast<double>(d.size()));
}

// The fall of the held-out sum of squares from `before` to `after`, in
// standard errors of that fall were the difference of the two predictions
// (d = e_before - e_after, sample by sample) a fixed signal against
// independent errors of the held-out variance s^2: 2 s |d| (docs/IDENTIFY.md,
// Method 4). Sample by sample, not over the ~5 min blocks: a fall confined to
// a few blocks drowns in the blocks' scatter (a paired test over the blocks,
// tried for every candidate, lost every warm-up of the development seeds).
double held_out_fall_z(const HeldOut& before, const HeldOut& after) {
  double fall = 0.0;
  double dd = 0.0;
  double sse = 0.0;
  double count = 0.0;
  for (Eigen::Index i = 0; i < after.error.size(); ++i) {
    const double b = before.error(i);
    const double a = after.error(i);
    if (!std::isfinite(a) || !std::isfinite(b)) continue;
    fall += b * b - a * a;
    dd += (b - a) * (b - a);
    sse += a * a;
    count += 1.0;
  }
  if (count < 1.0 || !(dd > 0.0) || !(sse > 0.0)) return 0.0;
  return fall / (2.0 * std::sqrt(sse / count) * std::sqrt(dd));
}

struct Trial {
  std::string effect;  // what it adds: one effect, or two joined by '+' (a masked pair)
  bool scanned = false;  // a probe with a scan (SelectionProblem::scan)
  double alternatives = 1.0;
  std::vector<std::string> effects;  // the model's, with what it adds
  std::vector<std::string> adds;     // what it adds, one name each
  Scored scored;
  CandidateScore score;
  EffectReadout readout;                // of the last effect it adds
  std::vector<EffectReadout> readouts;  // of each effect it adds, in the order of `adds`
  HeldOut before;  // the current model's, under this candidate's noise model
  HeldOut after;
  Eigen::VectorXd added_signal;
};

// A passing candidate's standing against the others of its round.
struct Standing {
  const Trial* trial = nullptr;
  double delta_bic = 0.0;
  HeldOut held;
};

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : "+") + n;
  return out;
}

bool in_group(const SelectionProblem& p, const std::string& a, const std::string& b) {
  for (const auto& g : p.confounded) {
    const bool has_a = std::find(g.begin(), g.end(), a) != g.end();
    const bool has_b = std::find(g.begin(), g.end(), b) != g.end();
    if (has_a && has_b) return true;
  }
  return false;
}

// The Newey-West long-run variance factor of an amplitude's estimate: the
// regressor with the other columns partialled out (Frisch-Waugh: the
// whitened Jacobian times the amplitude's column of (J'J)^-1) times the
// whitened residual, Bartlett weights over a bandwidth of three fitted
// wander correlation times and at least 30 min, long against the wander of
// a gyro (issue 22: 30..1000 s).
double amplitude_long_run_factor(const SelectionProblem& problem, const Scored& s, Eigen::Index index) {
  constexpr double kMinBandwidthS = 1800.0;
  const Eigen::VectorXd z = s.white_jacobian * s.fit.covariance_unscaled.col(index);
  const Eigen::VectorXd v = z.cwiseProduct(s.white_residual);
  const double span = problem.time_s.back() - problem.time_s.front();
  const double step = span / static_cast<double>(std::max<Eigen::Index>(1, v.size() - 1));
  const auto lags = static_cast<std::size_t>(std::max(kMinBandwidthS, 3.0 * s.noise.tau_s) / step);
  // Sums of v, not its variance about a mean: v has mean zero under the
  // model, and centring would remove the slow part that matters.
  const double gamma0 = v.squaredNorm();
  if (!(gamma0 > 0.0)) return 1.0;
  double factor = 1.0;
  const std::size_t n = static_cast<std::size_t>(v.size());
  for (std::size_t k = 1; k <= lags && k < n; ++k) {
    const double weight = 1.0 - static_cast<double>(k) / static_cast<double>(lags + 1);
    const auto kk = static_cast<Eigen::Index>(k);
    factor += 2.0 * weight * v.head(v.size() - kk).dot(v.tail(v.size() - kk)) / gamma0;
  }
  return std::max(1.0, factor);
}

// One candidate (or probe) on top of the current model: fit, evidence,
// held-out errors, readout, and the decision.
Trial try_candidate(const SelectionProblem& problem, const Criteria& criteria, const Scored& current,
                    const std::vector<std::vector<bool>>& scored, const std::vector<std::string>& effects,
                    const std::vector<std::string>& adds, int round, bool probe) {
  Trial trial;
  const std::string effect = adds.back();
  trial.effect = join(adds);
  trial.adds = adds;
  trial.effects = effects;
  trial.effects.insert(trial.effects.end(), adds.begin(), adds.end());
  ProbeScan scan;
  if (probe && problem.scan) {
    Eigen::MatrixXd design;
    Eigen::VectorXd offset;
    current.model.evaluate(current.fit.theta, design, offset);
    scan = problem.scan(effect, current.fit.residual, design);
  }
  const bool scanned = !scan.starts.empty();
  trial.scanned = scanned;
  trial.alternatives = scan.alternatives;
  SeparableModel model = problem.build(trial.effects);
  if (scanned) {
    model.theta_grid.clear();
    for (const auto& s : scan.starts) {
      std::vector<double> start = current.fit.theta;
      start.insert(start.end(), s.begin(), s.end());
      model.theta_grid.push_back(std::move(start));
    }
  } else if (!current.fit.theta.empty()) {
    // The effects already in keep their fitted theta as the start; only the
    // new effect's theta is searched on its grid (then LM refines all).
    std::set<std::vector<double>> starts;
    for (const auto& g : model.theta_grid) {
      std::vector<double> start = current.fit.theta;
      start.insert(start.end(), g.begin() + static_cast<std::ptrdiff_t>(current.fit.theta.size()), g.end());
      starts.insert(std::move(start));
    }
    model.theta_grid.assign(starts.begin(), starts.end());
  }
  SeparableFit ols = fit_separable(problem.y, model);
  const bool at_bound = ols.theta_at_bound;
  // A library effect is tested with the noise refitted by maximum likelihood
  // (the likelihood ratio of the two models, each with its own wander). A probe,
  // a catch-all with many degrees of freedom in time, is tested under the
  // current model's noise: a record holds few slow degrees of freedom, and
  // refitting the wander after the probe soaked part of it up would credit
  // the probe with the wander's variance too. A scanned probe, of few
  // parameters, is tested as an effect is.
  const bool fixed_noise = probe && !scanned && is_series(problem);
  trial.scored = score(problem, std::move(model), std::move(ols), fixed_noise ? &current.noise : nullptr,
                       is_series(problem) ? &current.noise : nullptr);
  const Scored& t = trial.scored;
  CandidateScore& s = trial.score;
  s.round = round;
  s.effect = trial.effect;

  const double n = static_cast<double>(problem.y.size());
  // A scanned probe's nonlinear parameters are paid for by the scan's
  // alternatives (below), not counted again.
  const double dk = std::max(1.0, scanned ? static_cast<double>(t.fit.beta.size() - current.fit.beta.size())
                                          : parameter_count(t.fit) - parameter_count(current.fit));
  double lr = 0.0;
  if (is_series(problem)) {
    lr = std::max(0.0, 2.0 * (t.log_likelihood - current.log_likelihood) / t.lrv_factor);
    s.p_value = chi_square_sf(lr, dk);
    s.delta_bic = lr - dk * std::log(n / t.lrv_factor);
  } else {
    const double dof = n - parameter_count(t.fit);
    const double fall = current.fit.sse - t.fit.sse;
    s.p_value = dof >= 1.0 && fall > 0.0 && t.fit.sse > 0.0 ? f_sf(fall / dk / (t.fit.sse / dof), dk, dof)
                                                            : (fall > 0.0 && t.fit.sse <= 0.0 ? 0.0 : 1.0);
    s.delta_bic = n * std::log(std::max(current.fit.sse, 1e-300) / std::max(t.fit.sse, 1e-300)) - dk * std::log(n);
  }

  if (probe && !scanned) {
    trial.readout.t_ratio = 1e9;  // a probe has no single amplitude; the test is joint
    trial.readout.in_bounds = true;
    trial.readouts = {trial.readout};
  } else {
    // Each effect added is read out, and each must hold on its own amplitude
    // (a pair is as strong as its weaker member): the largest long-run
    // factor of the amplitudes corrects the evidence, the smallest t-ratio
    // and every bound are the pair's.
    double long_run = 1.0;
    bool amplitudes = false;
    double t_ratio = std::numeric_limits<double>::infinity();
    bool in_bounds = true;
    for (const auto& name : adds) {
      EffectReadout r = problem.readout(name, trial.effects, t.fit, t.covariance);
      if (is_series(problem) && r.amplitude_index >= 0) {
        double f = amplitude_long_run_factor(problem, t, r.amplitude_index);
        if (r.second_amplitude_index >= 0) f = std::max(f, amplitude_long_run_factor(problem, t, r.second_amplitude_index));
        r.t_ratio /= std::sqrt(f);
        long_run = std::max(long_run, f);
        amplitudes = true;
      }
      t_ratio = std::min(t_ratio, r.t_ratio);
      in_bounds = in_bounds && r.in_bounds;
      trial.readouts.push_back(std::move(r));
    }
    trial.readout = trial.readouts.back();
    trial.readout.t_ratio = t_ratio;
    trial.readout.in_bounds = in_bounds;
    if (amplitudes) {
      s.long_run_factor = long_run;
      s.p_value = chi_square_sf(lr / s.long_run_factor, dk);
    }
  }
  if (scanned) {
    s.p_value = std::min(1.0, s.p_value * scan.alternatives);
    s.params = trial.readout.params;
  }
  s.t_ratio = trial.readout.t_ratio;
  s.in_bounds = trial.readout.in_bounds && (probe || !at_bound);

  // Both models' held-out errors under the candidate's noise: under the
  // current model's, the wander that holds a real effect's signal would track
  // it in the held-out blocks too, and the effect would gain nothing there
  // (docs/IDENTIFY.md, "Run 2 ... and what changed after it").
  const WanderNoise* noise = is_series(problem) ? &t.noise : nullptr;
  trial.after = held_out(problem, t.model, t.fit.theta, noise, scored);
  trial.before = held_out(problem, current.model, current.fit.theta, noise, scored);
  double sum_before = 0.0;
  double sum_after = 0.0;
  for (std::size_t f = 0; f < trial.after.fold_sse.size(); ++f) {
    sum_before += trial.before.fold_sse[f];
    sum_after += trial.after.fold_sse[f];
    if (trial.after.fold_sse[f] < trial.before.fold_sse[f]) ++s.folds_improved;
  }
  s.cv_gain = sum_before > 0.0 ? (sum_before - sum_after) / sum_before : 0.0;
  s.heldout_z = held_out_fall_z(trial.before, trial.after);
  trial.added_signal = t.fit.prediction - current.fit.prediction;

  char reason[96];
  // A probe's held-out test is one of evidence (Criteria::min_heldout_z).
  const bool by_evidence = probe && is_series(problem);
  const double max_p = scanned ? criteria.max_p_value_probe
                               : (is_series(problem) ? criteria.max_p_value : criteria.max_p_value_table);
  if (s.p_value > max_p) {
    std::snprintf(reason, sizeof reason, "evidence too weak (p = %.2g)", s.p_value);
    s.reason = reason;
  } else if (by_evidence && s.heldout_z < criteria.min_heldout_z) {
    std::snprintf(reason, sizeof reason, "held-out errors do not fall clear of their noise (z = %.2g)", s.heldout_z);
    s.reason = reason;
  } else if ((!by_evidence && s.cv_gain < criteria.min_cv_gain) ||
             s.folds_improved < std::min(criteria.min_folds_improved, problem.folds)) {
    s.reason = "held-out folds do not improve";
  } else if (is_series(problem) && s.t_ratio < criteria.min_t_ratio) {
    // Tables: the F-test is the amplitude's test (t^2 = F for one linear
    // parameter); a Wald ratio of a nonlinear parameter on a dozen points is
    // not a calibrated second opinion.
    s.reason = "confidence interval includes zero";
  } else if (!s.in_bounds) {
    s.reason = "parameters outside physical bounds";
  } else {
    s.passed = true;
  }
  return trial;
}

// A candidate that failed, though its amplitude stands clear of its
// standard error under its own noise and it is in bounds: on a series, the
// mark of an effect the wander fitted without it has absorbed (with another
// effect's signal), so that the likelihood gains little from it and its
// held-out errors hardly fall. A 250 s lag under a warm-up came to t = 10
// with p = 8e-4.
bool masked_by_noise(const SelectionProblem& problem, const Criteria& criteria, const CandidateScore& s) {
  return is_series(problem) && !s.passed && s.t_ratio >= criteria.min_t_ratio && s.in_bounds;
}

}  // namespace

SelectionResult select_effects(const SelectionProblem& problem, const Criteria& criteria,
                               const std::function<void(double)>& progress) {
  SelectionResult result;
  std::vector<std::string> effects;
  Scored current;
  {
    SeparableModel model = problem.build(effects);
    SeparableFit fit = fit_separable(problem.y, model);
    current = score(problem, std::move(model), std::move(fit));
  }
  result.baseline = current.fit;
  result.baseline_noise = current.noise;
  const std::vector<std::vector<bool>> scored = scored_rows(problem, current.model, current.fit.theta);
  const std::size_t n = static_cast<std::size_t>(problem.y.size());
  const double total_steps = static_cast<double>(problem.candidates.size() * 2 + problem.probes.size());
  double steps = 0.0;
  const auto step = [&] {
    if (progress) progress(std::min(0.99, ++steps / total_steps));
  };

  // Scanned probes already tried on the current model (a round they outdid
  // ends the search with the model as it was): not tried again below.
  std::vector<std::string> probed_current;
  for (int round = 1; round <= static_cast<int>(problem.candidates.size()); ++round) {
    std::vector<Trial> passed;
    std::vector<Trial> masked;
    // `adds` tried on top of a trial's model, listed as "name (with base)".
    const auto try_on_top = [&](const Trial& base, const std::vector<std::string>& adds, const std::string& name) {
      Trial t = try_candidate(problem, criteria, base.scored, scored, base.effects, adds, round, false);
      t.score.effect = name + " (with " + base.effect + ")";
      result.tried.push_back(t.score);
      return t;
    };
    for (const auto& effect : problem.candidates) {
      if (std::find(effects.begin(), effects.end(), effect) != effects.end()) continue;
      step();
      Trial trial = try_candidate(problem, criteria, current, scored, effects, {effect}, round, false);
      result.tried.push_back(trial.score);
      if (trial.score.passed) {
        passed.push_back(std::move(trial));
      } else if (masked_by_noise(problem, criteria, trial.score)) {
        masked.push_back(std::move(trial));
      }
    }
    // An effect whose evidence holds but whose held-out errors do not fall
    // enough may share the residual with another effect: the wander fitted
    // without either holds the other's signal and tracks it in the held-out
    // blocks too (issue 31: a 250 s lag with an 8 mV warm-up, answered none).
    // With the strongest such effect in, a second one may pass on top of it;
    // the two are then tried together, as one candidate that must pass every
    // test against the model without them, each on its own amplitude. A pair
    // is the best of the combinations looked at, and pays for them (as a
    // scanned probe does) where the probes are weighed against it below.
    if (passed.empty() && !masked.empty()) {
      double combinations = 0.0;
      std::sort(masked.begin(), masked.end(),
                [](const Trial& a, const Trial& b) { return a.score.delta_bic > b.score.delta_bic; });
      constexpr std::size_t kMaskedTried = 2;
      for (std::size_t m = 0; m < std::min(masked.size(), kMaskedTried); ++m) {
        const std::string& first = masked[m].effect;
        for (const auto& second : problem.candidates) {
          if (second == first || std::find(effects.begin(), effects.end(), second) != effects.end()) continue;
          if (in_group(problem, first, second)) continue;
          const bool done = std::any_of(passed.begin(), passed.end(), [&](const Trial& t) {
            return std::find(t.adds.begin(), t.adds.end(), first) != t.adds.end() &&
                   std::find(t.adds.begin(), t.adds.end(), second) != t.adds.end();
          });
          if (done) continue;
          const Trial on_top = try_on_top(masked[m], {second}, second);
          combinations += 1.0;
          if (!on_top.score.passed) continue;
          Trial pair = try_candidate(problem, criteria, current, scored, effects, {first, second}, round, false);
          result.tried.push_back(pair.score);
          if (pair.score.passed) passed.push_back(std::move(pair));
        }
      }
      for (Trial& t : passed) t.alternatives = combinations;
    }
    if (passed.empty()) break;
    std::sort(passed.begin(), passed.end(), [](const Trial& a, const Trial& b) {
      return a.score.delta_bic > b.score.delta_bic;
    });
    // The passing candidates compared with one another under one noise model
    // (that of the strongest): each was tested with its own wander refitted,
    // which would make their likelihoods and held-out errors incommensurate.
    std::vector<Standing> standings;
    {
      const WanderNoise* reference = is_series(problem) ? &passed.front().scored.noise : nullptr;
      const Scored base = reference ? score(problem, current.model, current.fit, reference) : current;
      for (const Trial& t : passed) {
        Standing r{&t, t.score.delta_bic, t.after};
        if (reference) {
          const Scored common = score(problem, t.scored.model, t.scored.fit, reference);
          const double dk = std::max(1.0, parameter_count(common.fit) - parameter_count(base.fit));
          r.delta_bic = 2.0 * (common.log_likelihood - base.log_likelihood) / common.lrv_factor -
                        dk * std::log(static_cast<double>(n) / common.lrv_factor);
          r.held = held_out(problem, t.scored.model, t.scored.fit.theta, reference, scored);
        }
        standings.push_back(std::move(r));
      }
      std::stable_sort(standings.begin(), standings.end(),
                       [](const Standing& a, const Standing& b) { return a.delta_bic > b.delta_bic; });
    }
    // A library effect is named only where it explains the structure better
    // than the probes of few parameters (a change of level, a periodic term,
    // the rate squared) tried on the same model: a drift or a warm-up that
    // only partly follows a step or a relaxation must not be claimed for it.
    // Compared as the candidates are, under the strongest's noise, each
    // probe's score less 2 ln(alternatives) for having been the best of a
    // scan (in place of a count of its scanned parameters), a masked pair's
    // likewise for the combinations it was found among. A probe that does
    // better ends the search: structure remains.
    if (problem.scan && is_series(problem)) {
      const WanderNoise& reference = passed.front().scored.noise;
      const Scored base = score(problem, current.model, current.fit, &reference);
      bool outdone = false;
      for (const auto& probe : problem.probes) {
        Trial t = try_candidate(problem, criteria, current, scored, effects, {probe}, round, true);
        if (!t.scanned) continue;
        probed_current.push_back(probe);
        result.tried.push_back(t.score);
        if (!t.score.passed) continue;
        const Scored common = score(problem, t.scored.model, t.scored.fit, &reference);
        const double dk = std::max(1.0, static_cast<double>(common.fit.beta.size() - base.fit.beta.size()));
        const double delta_bic = 2.0 * (common.log_likelihood - base.log_likelihood) / common.lrv_factor -
                                 dk * std::log(static_cast<double>(n) / common.lrv_factor) -
                                 2.0 * std::log(t.alternatives);
        if (delta_bic > standings.front().delta_bic - 2.0 * std::log(standings.front().trial->alternatives)) {
          outdone = true;
          if (std::find(result.unexplained.begin(), result.unexplained.end(), probe) == result.unexplained.end()) {
            result.unexplained.push_back(probe);
          }
        }
      }
      if (outdone) break;
      probed_current.clear();  // the best candidate joins the model below
    }
    const Trial& best = *standings.front().trial;
    std::vector<std::string> tied = best.adds;
    const auto tie_in = [&](const std::vector<std::string>& names) {
      for (const auto& name : names) {
        if (std::find(tied.begin(), tied.end(), name) == tied.end()) tied.push_back(name);
      }
    };
    for (std::size_t i = 1; i < standings.size(); ++i) {
      const Trial& other = *standings[i].trial;
      bool grouped = false;
      for (const auto& a : best.adds) {
        for (const auto& b : other.adds) grouped = grouped || in_group(problem, a, b);
      }
      const double r = correlation(best.added_signal, other.added_signal);
      const bool collinear = std::fabs(r) > criteria.max_signal_correlation;
      bool tie = collinear || grouped ||
                 standings.front().delta_bic - standings[i].delta_bic < criteria.ambiguous_delta_bic ||
                 held_out_tie(standings.front().held.unit_sse, standings[i].held.unit_sse, criteria.ambiguous_heldout_z);
      // Two effects the record cannot rank are alternatives only if neither
      // adds to the other: the runner-up passing every test on top of the
      // best means both are there (a lag and a warm-up, each explaining part
      // of the same residual), and the next round adds it. The runner-up
      // adding nothing to the best while the best adds to it means the best
      // explains what the runner-up does and more (a 120 s lag and the rate
      // sensitivity that follows part of it: the lag is the answer). Both
      // have passed every test alone; between them the question is the
      // likelihood's alone (an encompassing test): the runner-up without
      // evidence on top of the best, the best with evidence on top of it.
      // Its t-ratio and held-out gain on top of a partial stand-in are those
      // of what the stand-in left (a 0.5 mV ramp hysteresis on top of an
      // ambient sensitivity: p = 2e-7, t = 2.9, held-out gain 0.9 %).
      if (tie && !collinear && !grouped) {
        const Trial on_top = try_on_top(best, other.adds, other.effect);
        tie = !on_top.score.passed;
        const double max_p = is_series(problem) ? criteria.max_p_value : criteria.max_p_value_table;
        if (tie && on_top.score.p_value > max_p) {
          const Trial encompassing = try_on_top(other, best.adds, best.effect);
          tie = !(encompassing.score.p_value <= max_p && encompassing.score.in_bounds);
        }
      }
      if (tie) tie_in(other.adds);
      if (tie || std::fabs(r) >= criteria.near_alternative_correlation) {
        result.alternatives.push_back({best.effect, other.effect, r, !tie, ""});
      }
    }
    // A near-collinear candidate whose evidence and amplitude hold but whose
    // held-out errors fell too little alone (the record's noise too close to
    // its signal for a fold to show it) is weighed as a passing one: the best
    // must add evidence on top of it, or the record cannot tell them apart
    // (a rate sensitivity of 60 mV per C/s on 30..42 C, where the casing's
    // rate follows the room's difference: answered ambient_sensitivity alone).
    if (is_series(problem)) {
      for (const Trial& other : masked) {
        if (other.score.p_value > criteria.max_p_value) continue;
        if (std::find(tied.begin(), tied.end(), other.effect) != tied.end()) continue;
        const double r = correlation(best.added_signal, other.added_signal);
        if (std::fabs(r) < criteria.near_alternative_correlation) continue;
        const Trial encompassing = try_on_top(other, best.adds, best.effect);
        const bool tie = !(encompassing.score.p_value <= criteria.max_p_value && encompassing.score.in_bounds);
        if (tie) tie_in(other.adds);
        result.alternatives.push_back({best.effect, other.effect, r, !tie, ""});
      }
    }
    // A passing candidate the record cannot tell from a tied one (a
    // confounded pair: the rate and the ambient sensitivity where the casing
    // follows the room) is tied too, whatever its own standing.
    if (tied.size() > best.adds.size()) {
      for (const Trial& other : passed) {
        if (other.adds.size() != 1 || std::find(tied.begin(), tied.end(), other.effect) != tied.end()) continue;
        const bool confounded = std::any_of(tied.begin(), tied.end(), [&](const std::string& name) {
          return in_group(problem, name, other.effect);
        });
        if (!confounded) continue;
        tie_in(other.adds);
        const auto listed = std::find_if(result.alternatives.begin(), result.alternatives.end(),
                                         [&](const Alternative& a) { return a.other == other.effect; });
        if (listed != result.alternatives.end()) {
          listed->told_apart = false;
        } else {
          result.alternatives.push_back(
              {best.effect, other.effect, correlation(best.added_signal, other.added_signal), false, ""});
        }
      }
    }
    for (std::size_t k = 0; k < best.adds.size(); ++k) {
      AddedEffect added;
      added.effect = best.adds[k];
      added.params = best.readouts[k].params;
      added.delta_bic = best.score.delta_bic;
      added.rms_after = std::sqrt(best.scored.fit.sse / static_cast<double>(n));
      added.fold_rms_before = fold_rms(best.before);
      added.fold_rms_after = fold_rms(best.after);
      result.added.push_back(std::move(added));
    }
    current = best.scored;
    if (tied.size() > best.adds.size()) {
      std::sort(tied.begin(), tied.end(), [&](const std::string& a, const std::string& b) {
        const auto pa = std::find(problem.candidates.begin(), problem.candidates.end(), a);
        const auto pb = std::find(problem.candidates.begin(), problem.candidates.end(), b);
        return pa < pb;
      });
      result.ambiguous = tied;
      break;  // the best of the tied candidates still shows how far the gap closes
    }
    effects.insert(effects.end(), best.adds.begin(), best.adds.end());
  }

  if (result.ambiguous.empty()) {
    for (const auto& probe : problem.probes) {
      step();
      if (std::find(probed_current.begin(), probed_current.end(), probe) != probed_current.end()) continue;
      Trial trial = try_candidate(problem, criteria, current, scored, effects, {probe}, 0, true);
      result.tried.push_back(trial.score);
      if (trial.score.passed &&
          std::find(result.unexplained.begin(), result.unexplained.end(), probe) == result.unexplained.end()) {
        result.unexplained.push_back(probe);
      }
    }
  }
  if (progress) progress(1.0);

  // An alternative told apart that a later round added is an effect of its
  // own, not an alternative.
  std::erase_if(result.alternatives, [&](const Alternative& a) {
    return a.told_apart && std::find(effects.begin(), effects.end(), a.other) != effects.end();
  });
  if (!result.ambiguous.empty()) {
    // Effects already found stay listed in `added`; the verdict names the tie.
    result.verdict = "ambiguous:" + join(result.ambiguous);
  } else if (!result.unexplained.empty()) {
    result.verdict = effects.empty() ? "unexplained" : join(effects) + "+unexplained";
  } else {
    result.verdict = effects.empty() ? "none" : join(effects);
  }
  result.final_fit = current.fit;
  result.final_noise = current.noise;
  return result;
}

std::string verdict_statement(const SelectionResult& r) {
  const auto listed = [](const std::vector<std::string>& names, const char* conjunction) {
    std::string out;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (i > 0) out += i + 1 == names.size() ? conjunction : ", ";
      out += names[i];
    }
    return out;
  };
  if (!r.ambiguous.empty()) {
    // How alike the tied contributions are, against the strongest's.
    double lo = 1.0;
    double hi = -1.0;
    std::string strongest;
    for (const auto& a : r.alternatives) {
      if (a.told_apart) continue;
      lo = std::min(lo, a.correlation);
      hi = std::max(hi, a.correlation);
      strongest = a.effect;
    }
    char alike[160] = "";
    if (hi >= lo) {
      if (hi - lo < 5e-4) {
        std::snprintf(alike, sizeof alike, " (their fitted contributions correlate %.3f over the record)", hi);
      } else {
        std::snprintf(alike, sizeof alike, " (their fitted contributions correlate %.3f..%.3f with %s's)", lo, hi,
                      strongest.c_str());
      }
    }
    return "consistent with either " + listed(r.ambiguous, " or ") + alike + "; the record cannot tell them apart";
  }
  std::vector<std::string> found;
  for (const auto& a : r.added) found.push_back(a.effect);
  if (!r.unexplained.empty()) {
    // Each probe by name, and where a scanned one found the structure.
    std::vector<std::string> probes;
    for (const auto& name : r.unexplained) {
      std::string text = name;
      for (auto t = r.tried.rbegin(); t != r.tried.rend(); ++t) {
        if (t->effect != name || !t->passed || t->params.empty()) continue;
        for (std::size_t i = 0; i < t->params.size(); ++i) {
          char part[64];
          std::snprintf(part, sizeof part, "%s%s %.3g", i == 0 ? " at " : ", ", t->params[i].name.c_str(),
                        t->params[i].value);
          text += part;
        }
        break;
      }
      probes.push_back(text);
    }
    const std::string where = "(probe: " + listed(probes, " and ") + ")";
    return found.empty() ? "none of the library's effects explains the residual: structure remains " + where
                         : "consistent with " + listed(found, " and ") +
                               ", but structure remains that none of the library's effects explains " + where;
  }
  if (found.empty()) return "no structure beyond the baseline and its noise";
  return "consistent with " + listed(found, " and ");
}

}  // namespace gyrotc::identify
