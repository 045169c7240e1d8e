#pragma once

#include <cstddef>
#include <string>
#include <vector>

// What the discrepancy workflow reports, whatever the target: the baseline
// gap, where it is worst, the effects added (with parameters and standard
// errors), the verdict, and the curves to plot.
namespace gyrotc::identify {

// Thresholds of the decision. The defaults were fixed on the training seeds
// of tools/identify_sweep (docs/IDENTIFY.md) and are reported on other seeds.
struct Criteria {
  // p-value of the nested-model test an effect must reach: on time series
  // the likelihood ratio of the fits with white + wander noise (corrected by
  // the long-run variance), on static tables the F-test. A fixed p-value
  // makes the improvement demanded scale with the number of independent
  // samples; each was calibrated on simulated records of its kind.
  double max_p_value = 1e-5;
  double max_p_value_table = 1e-3;
  // The scanned probes (a change of level, a periodic term, the rate
  // squared): their p-value, already multiplied by the alternatives scanned,
  // rests on a wander refitted after them, which falls short of the true
  // wander's slow power (docs/IDENTIFY.md): on development seeds a 0.4 mV
  // change under 1000 s wander came to 9e-6 and a 0.13 mV periodic term
  // under 300 s wander to 1e-6 on records with no such structure.
  double max_p_value_probe = 1e-6;
  // |parameter| / standard error of the effect's amplitude (time series;
  // on tables the F-test is the amplitude's test).
  double min_t_ratio = 4.0;
  // Held-out (blocked cross-validation) sum of squares must fall by this
  // fraction, and in at least min_folds_improved of the folds.
  double min_cv_gain = 0.02;
  // A probe for structure outside the library, on a series, instead: the
  // fall in standard errors of itself (the two predictions' difference a
  // fixed signal against independent innovations). The probe asks whether
  // structure is left, a question of evidence, not of size; a fixed
  // fraction of the whitened residual also asks more of a slow term, which
  // the noise filter partly predicts away (the rate squared: 0.8-1.9 % at
  // p down to 1e-10). 3, not 2: at 2 a periodic term passes on a gapped
  // record that has none (chosen on development seeds: docs/IDENTIFY.md,
  // run 9).
  double min_heldout_z = 3.0;
  int min_folds_improved = 3;
  // Two passing candidates are reported as ambiguous when they are closer
  // than this in BIC, or their added signals correlate more than
  // max_signal_correlation, or the held-out error of the runner-up is not
  // worse than the best's by ambiguous_heldout_z standard errors (paired
  // over the held-out units: CV blocks, table points).
  double ambiguous_delta_bic = 30.0;
  double max_signal_correlation = 0.999;
  double ambiguous_heldout_z = 2.0;
  // A named effect's alternatives whose fitted contributions correlate with
  // its own at least this much over the record are reported beside it, with
  // the experiment that would tell them apart. One that failed only a
  // held-out test (its evidence and amplitude hold) is weighed as a passing
  // one is: if the named effect adds nothing on top of it, the record cannot
  // tell them apart and the verdict is ambiguous.
  double near_alternative_correlation = 0.9;
};

// Two candidates whose fitted contributions are alike over the record: the
// tied ones of an ambiguous verdict, or a named effect and its nearest
// alternative, which the record told apart.
struct Alternative {
  std::string effect;        // the named effect (the strongest of a tie)
  std::string other;         // the alternative
  double correlation = 0.0;  // of the two fitted contributions over the record
  bool told_apart = false;   // the record separated them (by delta BIC and the held-out errors, or the
                             // named effect adding on top of the other and not the reverse); false: tied
  std::string experiment;    // what to measure next to tell them apart (empty: nothing known)
};

struct EffectParam {
  std::string name;  // e.g. "tau_s"
  double value = 0.0;
  double std_error = 0.0;
};

struct AddedEffect {
  std::string effect;
  std::vector<EffectParam> params;
  double delta_bic = 0.0;
  double rms_after = 0.0;
  std::vector<double> fold_rms_before;  // held-out RMS per fold without / with it
  std::vector<double> fold_rms_after;
};

// One candidate tried in one round, and why it was or was not kept.
struct CandidateScore {
  int round = 0;
  std::string effect;
  double delta_bic = 0.0;
  double p_value = 1.0;  // of the nested-model test
  // Series: the long-run variance factor of the amplitude (1 = no serial
  // correlation left); the p-value and t-ratio are corrected by it.
  double long_run_factor = 1.0;
  double cv_gain = 0.0;  // fractional fall of the held-out sum of squares
  double heldout_z = 0.0;  // that fall in standard errors of itself (Criteria::min_heldout_z)
  int folds_improved = 0;
  double t_ratio = 0.0;
  bool in_bounds = false;
  bool passed = false;
  std::string reason;  // empty when passed
  // A scanned probe's fitted parameters (where the structure is: a level
  // change's time and size, a period); empty otherwise.
  std::vector<EffectParam> params;
};

struct Region {
  std::string name;     // "ramp up", "hold", "first 10 min", "band 20..30 C", ...
  double start = 0.0;   // in the units of Identification::x_name
  double end = 0.0;
  std::size_t samples = 0;
  double rms = 0.0;
  double mean = 0.0;
};

// Correlation of the baseline residual with a candidate driving signal.
struct SignalCorrelation {
  std::string signal;  // "dT/dt", "sign(dT/dt)", "time since power-on", "tec_a^2"
  double r = 0.0;      // Pearson correlation
};

struct Identification {
  std::string target;
  std::string units;   // units of the residual (mV, C, ln(Q), Hz)
  std::string x_name;  // "time_s" or "temp_c"

  // Parameters of the calibrated baseline worth reporting (may be empty);
  // on time series with the noise of the final model (white_sd_per_bin,
  // wander_sd, wander_tau_s), which the report says.
  std::vector<EffectParam> baseline_params;
  double baseline_rms = 0.0;
  double baseline_max_abs = 0.0;
  double whiteness_p_before = 0.0;  // Ljung-Box p-value of the residual

  std::vector<Region> regions;  // worst first
  std::vector<SignalCorrelation> correlations;  // time series only
  std::vector<AddedEffect> added;
  std::vector<CandidateScore> tried;
  // effect | a+b | none | ambiguous:a+b | unexplained | a+unexplained
  // ("unexplained": a generic probe found structure no library effect explains).
  std::string verdict;
  // The verdict in words: "consistent with thermal_lag", "no structure
  // beyond the baseline and its noise", "none of the library's effects
  // explains the residual (...)".
  std::string statement;
  std::vector<std::string> unexplained;  // the probes that passed
  std::vector<Alternative> alternatives;
  // Series: a noise parameter at the bound of its search, in words (the
  // baseline's wander at the record's quarter has taken structure).
  std::vector<std::string> noise_warnings;
  std::string note;     // why candidates were not tried (empty when all were)

  double final_rms = 0.0;
  double final_max_abs = 0.0;
  double whiteness_p_after = 0.0;
  double shrink = 1.0;

  // Curves for the plots (the fitted samples; binned for long records).
  std::vector<double> x;
  std::vector<double> measured;
  std::vector<double> baseline_model;
  std::vector<double> final_model;
  // The signal the first added (or ambiguous) effect acts through, and its name.
  std::string effect_signal_name;
  std::vector<double> effect_signal;
};

}  // namespace gyrotc::identify
