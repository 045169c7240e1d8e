#pragma once

#include <Eigen/Dense>

#include <functional>
#include <string>
#include <vector>

#include "gyrotc/algorithms/tune/residual_noise.hpp"
#include "gyrotc/algorithms/tune/thermal_model.hpp"

// Identifies the ThermalModel of one unit from its own record (issue 23): the
// columns a board has, time_s, sensor_c (casing DS18B20), tec_a (commanded)
// and, when the board has the second DS18B20, ambient_c; never the plant's
// true temperatures. The model's sensor reading is fitted to the record's by
// least squares (output error: the model runs open loop along the whole
// record with the recorded commands and ambient), with the Levenberg-
// Marquardt search and covariance of identify::fit_separable; standard errors
// are inflated for the residual's autocorrelation (identify::residual_stats'
// effective sample size). Without an ambient column the ambient is taken as
// constant and estimated with the rest. Where the record's ambient moved by
// 3 C or more, the sensor's share of the ambient (thermal_model.hpp) is
// searched as well and kept if it earns its place (Schwarz's criterion).
namespace gyrotc::tune {

struct TuneRecord {
  std::vector<double> time_s;
  std::vector<double> sensor_c;
  std::vector<double> tec_a;      // commanded, in effect from this row to the next
  std::vector<double> ambient_c;  // empty: no ambient sensor
};

struct Estimate {
  std::string name;
  std::string unit;
  double value = 0.0;
  double std_error = 0.0;
  bool determined = true;  // false: the record does not pin it down (see note)
  std::string note;
};

struct ThermalFit {
  ThermalModel model;
  ThermalState initial;
  bool ambient_measured = true;
  double ambient_c = 0.0;  // the estimated constant ambient (ambient_measured = false)
  double ambient_range_c = 0.0;     // how far the measured ambient moved over the record
  // The sensor's share of the ambient (ThermalModel::sensor_ambient_share) is
  // in the model: the ambient moved by at least 3 C, and the share earned its
  // place by Schwarz's criterion over the residual's effective samples.
  bool sensor_share_fitted = false;
  // The stage's own current limit (ThermalModel::stage_limit_a) is in the
  // model: the fit without it stayed above the DS18B20's quantisation floor,
  // and the limit earned its place by the same criterion.
  bool stage_limit_fitted = false;
  // A side node on the casing (ThermalModel::side_per_s, side_tau_s) is in
  // the model: the record has the ambient column, the fit without the node
  // stayed above the floor, its two parameters earned their place by the
  // same criterion, and the record pins both down (within a factor e) with
  // the Peltier term still screened.
  bool side_fitted = false;
  // The fit without the side node (model itself where none was fitted): the
  // PID's design takes it (tune/controller_design.hpp; its gains were built
  // and measured on that structure).
  ThermalModel lumped_model;
  std::vector<Estimate> estimates;

  // Fit quality.
  std::size_t samples = 0;
  double duration_s = 0.0;
  double rms_c = 0.0;
  double max_abs_c = 0.0;
  double r_squared = 0.0;
  double quantisation_rms_c = 0.0625 / 3.4641016151377544;  // DS18B20 step / sqrt(12)
  double lag1_autocorrelation = 0.0;
  double effective_samples = 0.0;
  // The noise the covariance assumes (residual_noise.hpp).
  ResidualNoise noise;
  double ljung_box_p = 0.0;
  bool rail_reached = false;   // commands the identified rail clipped
  double max_command_a = 0.0;  // largest |tec_a| of the record
  double heating_limit_a = 0.0;  // largest / smallest command: the experiment's limits
  double cooling_limit_a = 0.0;

  std::vector<double> prediction;  // modelled reading at every record row

  // Internal: the fitted parameter vector and its covariance, for the
  // uncertainty of derived quantities.
  std::vector<double> theta;
  Eigen::MatrixXd covariance;
};

// Throws std::invalid_argument with one line saying what is wrong or missing:
// unequal columns, time not increasing (naming the row), a gap longer than
// 30 s, a record shorter than 30 min (times experiment_scale), no excitation (the current hardly
// changes), a flat record (the casing hardly moves), a saturated experiment
// (the current sits at one limit), a current that moves the casing against its
// sign (the record fits far better with the current reversed: a TEC wired the
// wrong way round), or a current without effect on the casing.
// experiment_scale: the record is an ExperimentPlan::scaled(experiment_scale)
// experiment, and its shortest acceptable length scales with it.
ThermalFit identify_thermal(const TuneRecord& record, double experiment_scale = 1.0);

// Standard error of a derived quantity f(model) by the delta method over the
// fitted parameters' covariance.
double std_error_of(const ThermalFit& fit, const std::function<double(const ThermalModel&)>& f);

}  // namespace gyrotc::tune
