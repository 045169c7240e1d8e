#pragma once

#include <Eigen/Dense>
#include <memory>

#include "gyrotc/algorithms/control/housing_model.hpp"

// The model-based temperature loop (issue 72): a Kalman filter on a
// HousingModel, with two more states, an unknown heat into the TEC's casing
// side (a random walk: what gives the loop its integral action and takes up
// what the model gets wrong) and the ambient (a random walk, seen by the
// ambient sensor, wherever the model puts it: on the ambient or on a node
// such as a heat sink), and LQ state feedback around the steady state that
// holds the setpoint:
//
//   every period, with the casing reading y (and an ambient reading when a
//   new one came):
//     z = z- + K_k (y - h(z-))                    the filter's update
//     I_ss: the current whose steady state (at the estimated ambient and
//           heat) holds the setpoint; x_ss that steady state
//     I = clamp(I_ss - K (x - x_ss), the range the stage can apply now)
//     z- = the model over the period with I         the prediction
//
// The prediction runs the model's nonlinear TEC (Peltier, Joule, the stage's
// swing) at the current applied, and the filter's covariance is propagated
// on the model linearised there, every period (an extended Kalman filter:
// the warm-up at the current limit is predicted as well as the hold, and the
// ambient sensor's readings count whenever they come). The LQ gain K is
// designed on the model linearised at the setpoint at the design ambient.
// The clamp is the anti-windup: the loop has no integrator of its own, its
// integral is the filter's estimate of a heat, which the current applied
// explains whether or not it saturates.
//
// The same filter checks its casing sensor (issue 75, item 3): from the
// tick the reading last changed, a shadow of the filter goes on without the
// casing reading (the currents applied and the ambient readings only), its
// covariance growing by the model's process noise. A healthy reading that
// stays on one step stays where the shadow puts it, within its uncertainty;
// a frozen one is left behind once the ambient or the current moves the
// housing (reading_surprise()). The loop's own filter cannot tell: its
// unknown heat takes up whatever a frozen reading says.
namespace gyrotc::control {

struct ObserverLoopSpec {
  double period_s = 1.0;
  double setpoint_c = 55.0;         // the linearisation point
  double design_ambient_c = 16.0;
  // The filter's measurement noise: each sensor's own noise and its
  // quantisation (a uniform error of one step: step^2 / 12).
  double reading_noise_c = 0.0;
  double ambient_noise_c = 0.0;
  double reading_step_c = 0.0625;   // DS18B20 12-bit
  // The least noise the quantised update assumes, in steps (observer_loop.cpp:
  // quantised_noise_var). 0.1 step: on the suite's plants 0 let the filter grow sure of
  // a wrong temperature inside one step (0.094 and 0.272 C held on two), 0.3
  // held the network plants up to 3 mC worse.
  double noise_floor_steps = 0.1;
  // The filter's process noise: the unknown heat's and the ambient's random
  // walks, and a white error per state (what the model does not know). The
  // defaults are the reference loop's, whose model is the plant: a heat of
  // 0.1 mW/s^0.5 (what its quantised readings cannot pin down), an ambient
  // that a chamber moves at 1 C/min.
  double disturbance_w_per_sqrt_s = 1e-4;
  double ambient_c_per_sqrt_s = 0.05;
  double node_c_per_sqrt_s = 2e-4;
  // The unknown heat's standard deviation at the start: half a watt is a
  // large error in what the model knows of a housing's heat.
  double initial_heat_w = 0.5;
  // The LQ weights: an error of error_scale_c in the held temperature costs
  // as much as current_scale_a of current away from the holding current.
  // Softer (a larger ratio) overshoots less after the warm-up at the
  // current limit; livelier holds no closer on 1/16 C readings.
  double error_scale_c = 0.01;
  double current_scale_a = 0.02;
  // The casing's (the TEC's second side's) deviation in the LQ cost, as a
  // share of the held temperature's, where the loop holds another node: 0,
  // the held node alone. An identified housing's held node is a lag that a
  // record cannot place (a DS18B20's own package on the casing, or a node of
  // its own): holding it alone overshoots the casing where the lag is the
  // package's, holding the casing brakes a lag too early where it is a node.
  double casing_weight = 0.0;
  double max_step_s = 0.1;          // the model's integration step

  bool operator==(const ObserverLoopSpec&) const = default;
};

struct ObserverLoopDesign {
  HousingModel model;
  ObserverLoopSpec spec;
  double operating_current_a = 0.0;    // holds the setpoint at the design ambient
  Eigen::RowVectorXd feedback;         // state_count(), A per C
  // Spectral radii at the design point, < 1 is stable: the filter's
  // (stationary, with the casing reading alone) and the loop's.
  double observer_radius = 0.0;
  double loop_radius = 0.0;
};

// The current within +/- limit_a whose steady state holds setpoint_c at
// ambient_c (no unknown heat): the root on the heating side of the TEC's
// maximum cooling, as the loop's own search finds it. NaN when the stage
// cannot hold it there.
double holding_current_a(const HousingModel& model, double setpoint_c, double ambient_c, double limit_a);

// Throws std::invalid_argument when the model is not valid, cannot hold the
// setpoint at the design ambient, or a Riccati equation has no solution.
ObserverLoopDesign design_observer_loop(const HousingModel& model, const ObserverLoopSpec& spec);

// Where a running loop leaves the housing, on the sensors' scales (their
// offsets in): what another loop takes over from at a reload.
struct LoopHandover {
  double reading_c = 0.0;          // the casing reading, or the loop's unrounded estimate of it
  double ambient_reading_c = 0.0;  // NaN when there is no ambient reading
  double current_a = 0.0;          // the current applied
};

// The loop at run time: tick() allocates nothing once constructed (the
// real-time thread runs it).
class ObserverLoop {
 public:
  explicit ObserverLoop(std::shared_ptr<const ObserverLoopDesign> design);

  // The loop is stopped (a fault, the TEC off): the filter goes on with
  // what it knows. Without keep_heat the estimated heat starts again from 0
  // (a stop that is not a fault's); with it, it is kept (what the loop learnt
  // of the load). The first tick ever starts the filter from the readings
  // (every node at the casing's, the ambient at its sensor's).
  void restart(bool keep_heat) noexcept;
  // Takes over from another loop (a reload that changes the model, without a
  // kick): the filter starts at rest where the other left the housing, every
  // node at the steady state of the current it applied, with the unknown
  // heat that makes that steady state read what it read. Holding there, the
  // first period's current is the one applied, and the filter learns the
  // rest from the readings as after any start.
  void adopt(const LoopHandover& from) noexcept;
  // What another loop takes over from this one (after a tick).
  LoopHandover handover() const noexcept;
  // A period without a tick (the loop off or holding): the filter predicts
  // with the current the TEC had, without a reading.
  void coast(double current_a) noexcept;
  // One period, as the header says. reading_age_s: how long ago the casing
  // reading was measured (a DS18B20 samples at its conversion's start, and
  // the period takes the last reading delivered): the filter compares it
  // with the model's reading at that time. ambient_reading_c: a reading of
  // the ambient sensor that came since the last tick, NaN when none did.
  // Returns the current, within [min_a, max_a].
  double tick(double reading_c, double reading_age_s, double ambient_reading_c, double setpoint_c, double min_a,
              double max_a) noexcept;

  bool saturated() const noexcept { return saturated_; }
  // Whether a tick has started the filter (the estimates mean nothing before).
  bool started() const noexcept { return started_; }
  // The estimates after the last tick's update.
  double controlled_estimate_c() const noexcept;
  double node_estimate_c(int node) const noexcept { return posterior_(node); }
  double heat_estimate_w() const noexcept { return posterior_(heat_index()); }
  double ambient_estimate_c() const noexcept { return posterior_(ambient_index()); }
  double holding_current_a() const noexcept { return holding_a_; }
  // How far the last tick's casing reading, unchanged since the shadow
  // started, lay outside what the shadow expects: the distance beyond
  // kSurpriseSlackSteps steps and kSurpriseModelError of the move the
  // shadow predicts since it started, in the standard deviations of its
  // reading (the shadow's spread and the reading's noise). 0 when the
  // reading changed at that tick or lay within.
  double reading_surprise() const noexcept { return surprise_; }
  // Two steps of slack: a DS18B20's reading can stay a step off while its
  // temperature sits on a step's edge, and the model's rounding reaches one more.
  static constexpr double kSurpriseSlackSteps = 2.0;
  // A model from a unit's own record can be wrong by a factor in how fast
  // the housing moves (the suite's infeasible plants, warming for hours at
  // the current limit: 3x); half the predicted move is slack, so that a
  // healthy reading is taken for a stuck one only by a model 6x off.
  static constexpr double kSurpriseModelError = 0.5;

 private:
  int heat_index() const noexcept { return design_->model.state_count(); }
  int ambient_index() const noexcept { return design_->model.state_count() + 1; }
  double initial_heat_var() const noexcept { return design_->spec.initial_heat_w * design_->spec.initial_heat_w; }
  void start(double reading_c, double ambient_reading_c) noexcept;
  // A quantised scalar reading: h' z + noise (variance noise_var) rounded to
  // a multiple of step_c gave seen_c (the offset taken off). The update
  // matches the posterior's mean and covariance given that the unrounded
  // value lay within half a step of seen_c (a Gaussian prior, an interval
  // observed): a reading that stays on one step tells where it is not, as
  // far as the model carries it, instead of pulling the estimate to the
  // step's middle as white quantisation noise would.
  // expected_c: the model's unrounded reading (h' z, or at the reading's time).
  // On the estimate (z, p): the filter's or the shadow's.
  void update(Eigen::VectorXd& z, Eigen::MatrixXd& p, const Eigen::VectorXd& h, double seen_c, double expected_c,
              double step_c, double noise_var) noexcept;
  // z over one period with current_a, and the covariance with it.
  void predict(double current_a) noexcept;
  // The shadow over the same period: its own state, the filter's transition
  // (linearised at the filter's estimate, a degree or so away).
  void predict_shadow(double current_a) noexcept;
  // The shadow's verdict on the tick's casing reading, before the filter's update.
  void check_reading(double seen_c, double noise_var) noexcept;

  std::shared_ptr<const ObserverLoopDesign> design_;
  HousingStepper stepper_;
  Eigen::VectorXd z_;          // (state, heat, ambient): the prediction for the next tick
  Eigen::MatrixXd p_;          // its covariance
  Eigen::MatrixXd f_;          // the period's transition, linearised
  Eigen::MatrixXd fp_;         // scratch: f_ p_
  Eigen::MatrixXd w_;          // the period's process noise
  Eigen::VectorXd h_casing_;
  Eigen::VectorXd h_ambient_;
  Eigen::VectorXd gain_;         // P h
  Eigen::VectorXd x_;          // scratch: the thermal state
  Eigen::VectorXd base_;
  Eigen::VectorXd xss_;        // the steady state that holds the setpoint
  Eigen::VectorXd probe_;
  Eigen::VectorXd posterior_;  // the last tick's updated estimate
  // The shadow: the filter's estimate when the reading last changed, run on
  // without casing readings.
  Eigen::VectorXd shadow_z_;
  Eigen::MatrixXd shadow_p_;
  bool shadow_started_ = false;
  double shadow_reading_c_ = 0.0;  // the reading it started at (offset taken off)
  double shadow_start_c_ = 0.0;    // the filter's (unrounded) reading then
  double surprise_ = 0.0;
  double last_current_a_ = 0.0;  // applied since the last tick
  double holding_a_ = 0.0;
  bool started_ = false;
  bool saturated_ = false;
};

}  // namespace gyrotc::control
