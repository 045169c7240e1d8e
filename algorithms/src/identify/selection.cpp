#include "gyrotc/algorithms/identify/selection.hpp"

#include <algorithm>
#include <cmath>
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

// Held-out sum of squares per fold of the model with `effects`.
std::vector<double> fold_sse(const SelectionProblem& problem, const SeparableModel& model,
                             const SeparableFit& fit) {
  std::vector<double> sse(static_cast<std::size_t>(problem.folds), 0.0);
  const Eigen::Index n = problem.y.size();
  for (int f = 0; f < problem.folds; ++f) {
    std::vector<bool> train(static_cast<std::size_t>(n));
    std::vector<Eigen::Index> train_rows;
    for (Eigen::Index i = 0; i < n; ++i) {
      train[static_cast<std::size_t>(i)] = problem.fold_of[static_cast<std::size_t>(i)] != f;
      if (train[static_cast<std::size_t>(i)]) train_rows.push_back(i);
    }
    std::vector<double> theta = fit.theta;
    if (problem.refit_theta_in_cv && !theta.empty()) {
      Eigen::VectorXd train_y(static_cast<Eigen::Index>(train_rows.size()));
      for (std::size_t r = 0; r < train_rows.size(); ++r) {
        train_y(static_cast<Eigen::Index>(r)) = problem.y(train_rows[r]);
      }
      // LM from the full-data optimum: the fold moves it only a little.
      SeparableModel sub = subset_model(model, train_rows);
      sub.theta_grid = {fit.theta};
      theta = fit_separable(train_y, sub).theta;
    }
    const Eigen::VectorXd prediction = predict_with_theta(problem.y, model, theta, train);
    std::vector<bool> covered(static_cast<std::size_t>(n), true);
    if (!problem.coverage_key.empty()) {
      const auto cell = [&](Eigen::Index i) {
        return static_cast<long>(std::floor(problem.coverage_key[static_cast<std::size_t>(i)] /
                                            problem.coverage_cell));
      };
      std::map<long, int> training_count;
      for (Eigen::Index i : train_rows) ++training_count[cell(i)];
      for (Eigen::Index i = 0; i < n; ++i) {
        const auto it = training_count.find(cell(i));
        covered[static_cast<std::size_t>(i)] = it != training_count.end() && it->second >= 3;
      }
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!train[static_cast<std::size_t>(i)] && covered[static_cast<std::size_t>(i)]) {
        const double r = problem.y(i) - prediction(i);
        sse[static_cast<std::size_t>(f)] += r * r;
      }
    }
  }
  return sse;
}

std::vector<double> fold_rms(const SelectionProblem& problem, const std::vector<double>& sse) {
  std::vector<double> counts(sse.size(), 0.0);
  for (int f : problem.fold_of) counts[static_cast<std::size_t>(f)] += 1.0;
  std::vector<double> out(sse.size());
  for (std::size_t f = 0; f < sse.size(); ++f) {
    out[f] = counts[f] > 0 ? std::sqrt(sse[f] / counts[f]) : 0.0;
  }
  return out;
}

double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd ac = a.array() - a.mean();
  const Eigen::VectorXd bc = b.array() - b.mean();
  const double denom = ac.norm() * bc.norm();
  return denom > 0.0 ? ac.dot(bc) / denom : 0.0;
}

struct Trial {
  std::string effect;
  SeparableFit fit;
  CandidateScore score;
  EffectReadout readout;
  std::vector<double> fold_sse_after;
  Eigen::VectorXd added_signal;
};

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : "+") + n;
  return out;
}

}  // namespace

SelectionResult select_effects(const SelectionProblem& problem, const Criteria& criteria,
                               const std::function<void(double)>& progress) {
  SelectionResult result;
  std::vector<std::string> effects;
  SeparableModel current_model = problem.build(effects);
  SeparableFit current = fit_separable(problem.y, current_model);
  result.baseline = current;
  std::vector<double> current_fold_sse = fold_sse(problem, current_model, current);
  const std::size_t n = static_cast<std::size_t>(problem.y.size());
  const double total_steps = static_cast<double>(problem.candidates.size() * 2);
  double steps = 0.0;

  for (int round = 1; round <= static_cast<int>(problem.candidates.size()); ++round) {
    std::vector<Trial> passed;
    for (const auto& effect : problem.candidates) {
      if (std::find(effects.begin(), effects.end(), effect) != effects.end()) continue;
      if (progress) progress(std::min(0.99, ++steps / total_steps));
      Trial trial;
      trial.effect = effect;
      std::vector<std::string> with = effects;
      with.push_back(effect);
      SeparableModel model = problem.build(with);
      if (!current.theta.empty()) {
        // The effects already in keep their fitted theta as the start; only
        // the new effect's theta is searched on its grid (then LM refines all).
        std::set<std::vector<double>> starts;
        for (const auto& g : model.theta_grid) {
          std::vector<double> start = current.theta;
          start.insert(start.end(), g.begin() + static_cast<std::ptrdiff_t>(current.theta.size()), g.end());
          starts.insert(std::move(start));
        }
        model.theta_grid.assign(starts.begin(), starts.end());
      }
      trial.fit = fit_separable(problem.y, model);
      CandidateScore& s = trial.score;
      s.round = round;
      s.effect = effect;

      const double rho =
          problem.autocorrelated ? lag1_autocorrelation(as_span(trial.fit.residual)) : 0.0;
      const double n_eff = effective_sample_size(n, rho);
      const double dk = parameter_count(trial.fit) - parameter_count(current);
      s.delta_bic = n_eff * std::log(std::max(current.sse, 1e-300) / std::max(trial.fit.sse, 1e-300)) -
                    dk * std::log(n_eff);

      const double dof = std::max(1.0, static_cast<double>(n) - parameter_count(trial.fit));
      const double inflation = (1.0 + rho) / (1.0 - rho);
      const Eigen::MatrixXd covariance =
          trial.fit.covariance_unscaled * (trial.fit.sse / dof * inflation);
      trial.readout = problem.readout(effect, with, trial.fit, covariance);
      s.t_ratio = trial.readout.t_ratio;
      s.in_bounds = trial.readout.in_bounds && !trial.fit.theta_at_bound;

      trial.fold_sse_after = fold_sse(problem, model, trial.fit);
      double before = 0.0;
      double after = 0.0;
      for (std::size_t f = 0; f < trial.fold_sse_after.size(); ++f) {
        before += current_fold_sse[f];
        after += trial.fold_sse_after[f];
        if (trial.fold_sse_after[f] < current_fold_sse[f]) ++s.folds_improved;
      }
      s.cv_gain = before > 0.0 ? (before - after) / before : 0.0;
      trial.added_signal = trial.fit.prediction - current.prediction;

      if (s.delta_bic < criteria.min_delta_bic) {
        s.reason = "delta BIC below threshold";
      } else if (s.cv_gain < criteria.min_cv_gain ||
                 s.folds_improved < std::min(criteria.min_folds_improved, problem.folds)) {
        s.reason = "held-out folds do not improve";
      } else if (s.t_ratio < criteria.min_t_ratio) {
        s.reason = "confidence interval includes zero";
      } else if (!s.in_bounds) {
        s.reason = "parameters outside physical bounds";
      } else {
        s.passed = true;
      }
      result.tried.push_back(s);
      if (s.passed) passed.push_back(std::move(trial));
    }
    if (passed.empty()) break;
    std::sort(passed.begin(), passed.end(), [](const Trial& a, const Trial& b) {
      return a.score.delta_bic > b.score.delta_bic;
    });
    const Trial& best = passed.front();
    std::vector<std::string> tied{best.effect};
    for (std::size_t i = 1; i < passed.size(); ++i) {
      const bool close_bic =
          best.score.delta_bic - passed[i].score.delta_bic < criteria.ambiguous_delta_bic;
      const bool alike = std::fabs(correlation(best.added_signal, passed[i].added_signal)) >
                         criteria.max_signal_correlation;
      if (close_bic || alike) tied.push_back(passed[i].effect);
    }
    AddedEffect added;
    added.effect = best.effect;
    added.params = best.readout.params;
    added.delta_bic = best.score.delta_bic;
    added.rms_after = std::sqrt(best.fit.sse / static_cast<double>(n));
    added.fold_rms_before = fold_rms(problem, current_fold_sse);
    added.fold_rms_after = fold_rms(problem, best.fold_sse_after);
    if (tied.size() > 1) {
      std::sort(tied.begin(), tied.end(), [&](const std::string& a, const std::string& b) {
        const auto pa = std::find(problem.candidates.begin(), problem.candidates.end(), a);
        const auto pb = std::find(problem.candidates.begin(), problem.candidates.end(), b);
        return pa < pb;
      });
      result.ambiguous = tied;
      // The best of the tied candidates still shows how far the gap closes.
      result.added.push_back(std::move(added));
      current = best.fit;
      break;
    }
    effects.push_back(best.effect);
    result.added.push_back(std::move(added));
    current = best.fit;
    current_model = problem.build(effects);
    current_fold_sse = best.fold_sse_after;
  }
  if (progress) progress(1.0);

  if (!result.ambiguous.empty()) {
    // Effects already found stay listed in `added`; the verdict names the tie.
    result.verdict = "ambiguous:" + join(result.ambiguous);
  } else {
    result.verdict = effects.empty() ? "none" : join(effects);
  }
  result.final_fit = current;
  return result;
}

}  // namespace gyrotc::identify
