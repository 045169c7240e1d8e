#pragma once

namespace gyrotc::control {

// Parameters of the integral-separated incremental PID of the seed (Section 6.1,
// Eq. 17/18). The seed quotes its tuning as Kp = 0.48, KI = Kp*T/TI = 0.32,
// KD = Kp*TD/T = 10 with T = 2 s; the defaults below are those numbers
// expressed as TI and TD.
struct PidParams {
  double kp = 0.48;                      // Section 6.1: Kp = 0.48
  double ti_s = 0.48 * 2.0 / 0.32;       // Section 6.1: KI = Kp*T/TI = 0.32 -> TI = 3 s
  double td_s = 10.0 * 2.0 / 0.48;       // Section 6.1: KD = Kp*TD/T = 10 -> TD = 41.67 s
  double period_s = 2.0;                 // Section 6.1: sampling interval T = 2 s
  double xi_c = 0.5;                     // Section 6.1: separation threshold 0.5 C
  // Output limits in the output's unit (TEC current, A). Not from the seed:
  // a symmetric placeholder; the controller configuration sets the real TEC
  // current limit.
  double out_min = -2.0;
  double out_max = 2.0;

  // The seed's gain form: KI = Kp*T/TI, KD = Kp*TD/T.
  static PidParams from_gains(double kp, double ki, double kd, double period_s);
  double ki() const { return kp * period_s / ti_s; }
  double kd() const { return kp * td_s / period_s; }
};

// Throws std::invalid_argument naming the field when the parameters cannot make
// a controller (non-positive Kp/TI/T, negative TD or xi, out_min >= out_max,
// non-finite values).
void validate(const PidParams& params);

// Integral-separated incremental PID, seed Eq. 17:
//
//   du(k) = A e(k) - B e(k-1) + C e(k-2),   e(k) = c(k) - r(k) (measured - setpoint)
//   A = Kp (1 + beta T/TI + TD/T),  B = Kp (1 + 2 TD/T),  C = Kp TD/T
//
// with beta = 1 while |e(k)| < xi (PID) and beta = 0 while |e(k)| >= xi (PD,
// as the seed's prototype runs it, Section 4: "higher than or equal to 0.5 C";
// Eq. 18 read as Eq. 17 with the integral term removed: the printed Eq. 18
// drops u(k-1) and keeps T/TI in A', which contradicts the text around it).
//
// Sign: with e = measured - setpoint, Eq. 17's u rises when the casing is too
// hot. This class outputs TEC current with positive = heating, so it applies
// the increment with the opposite sign: u(k) = u(k-1) - du(k). A casing colder
// than the setpoint (e < 0) therefore drives the output up (heat).
//
// Saturation and anti-windup. The recurrence runs on an internal, unclamped
// state v; the output is v clamped to the limits of that step: [out_min,
// out_max], or the limits the caller passes for the step. A caller that adds
// a feed-forward ff to the output and clamps the sum to the TEC's limits
// [lo, hi] (which may move with the OPA548's rail limit) passes [lo - ff,
// hi - ff], so that saturation and anti-windup refer to the current actually
// applied, not to the PID's share of it (issue 22). v is exactly the
// positional PID  -(Kp e + KD (e(k) - e(k-1))) + I  computed incrementally, so
// its proportional and derivative parts can never wind up (they are functions
// of the current error). Only the integral can, and it is stopped by
// conditional integration: beta is also forced to 0 when the output is
// saturated and the integral increment would push it further out. Clamping v
// itself (the textbook velocity-form anti-windup) would lose the proportional
// action during a large setpoint step: from a cold start the output would fall
// off its rail by Kp per degree of warming and stall far below the setpoint.
//
// Bumpless start: reset(output) makes the integral part start at `output` and
// the first step after it uses e(k-1) = e(k-2) = e(k), so there is no
// derivative kick; a start at zero error continues exactly at `output`.
// Restart after a stop (a sensor fault): reset(integral()) as it was at the
// stop. The integral is what the PID learnt of the load; the proportional
// part answers the error as it is now. Restarting from the whole output
// instead would take the error at the restart for the setpoint's: outside
// the separation band the PD has no integral to undo that, and a casing that
// fell 3 C while the TEC was off stayed 3 C low for good.
//
// Real-time safe: step() does not allocate, lock or throw. A non-finite
// measurement or setpoint leaves the state and the output unchanged.
class IncrementalPid {
 public:
  explicit IncrementalPid(const PidParams& params);

  // One control period: returns the new output (positive heats), within
  // [out_min, out_max] of the parameters.
  double step(double measured, double setpoint) noexcept;
  // The same within [out_min, out_max] for this step only (out_max below
  // out_min is taken as out_min).
  double step(double measured, double setpoint, double out_min, double out_max) noexcept;
  // Clears the error history; the integral part restarts at `output` (clamped
  // to the output limits).
  void reset(double output = 0.0) noexcept;
  // New gains, period, band and limits from the next step on, bumplessly: the
  // output and the error history carry over, so the velocity form's next
  // increment is the new gains' answer to the error's change (no proportional
  // or derivative kick from the change itself). A setpoint changed at the
  // same time is a step like any other (ramp it to avoid the kick). `params`
  // must be valid (validate()).
  void retune(const PidParams& params) noexcept;

  double output() const noexcept { return output_; }
  // The integral part I of the last output, v = -(Kp e + KD (e(k) - e(k-1))) + I;
  // before the first step, the value reset() started it at.
  double integral() const noexcept;
  // True when the last step's unclamped output lay outside the limits.
  bool saturated() const noexcept { return saturated_; }
  // True when the last step ran with the integral term (beta = 1).
  bool integrating() const noexcept { return integrating_; }
  double last_error() const noexcept { return e1_; }
  const PidParams& params() const noexcept { return params_; }

  // Eq. 17 coefficients; a(beta) with beta = 1 (PID) or 0 (PD).
  double a(bool with_integral) const noexcept { return with_integral ? a_pid_ : a_pd_; }
  double b() const noexcept { return b_; }
  double c() const noexcept { return c_; }

 private:
  PidParams params_;
  double a_pid_;
  double a_pd_;
  double b_;
  double c_;
  double state_ = 0.0;   // v: unclamped output
  double output_ = 0.0;  // v clamped to the limits
  double e1_ = 0.0;      // e(k-1)
  double e2_ = 0.0;      // e(k-2)
  bool started_ = false;
  bool saturated_ = false;
  bool integrating_ = false;
};

}  // namespace gyrotc::control
