#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/control/pid.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::control::IncrementalPid;
using gyrotc::control::PidParams;

namespace {

// Wide limits so that the controller never saturates.
PidParams unsaturated_params() {
  PidParams p;
  p.out_min = -1e9;
  p.out_max = 1e9;
  return p;
}

}  // namespace

TEST_CASE("default parameters are the seed's Kp 0.48, KI 0.32, KD 10, T 2 s, xi 0.5 C") {
  const PidParams p;
  CHECK(p.kp == Approx(0.48));
  CHECK(p.ki() == Approx(0.32));
  CHECK(p.kd() == Approx(10.0));
  CHECK(p.period_s == Approx(2.0));
  CHECK(p.xi_c == Approx(0.5));
}

TEST_CASE("A, B, C follow Eq. 17 from Kp, TI, TD and T") {
  const IncrementalPid pid{PidParams{}};
  // A = Kp(1 + T/TI + TD/T) = Kp + KI + KD; B = Kp(1 + 2TD/T) = Kp + 2KD; C = KD.
  CHECK(pid.a(true) == Approx(0.48 + 0.32 + 10.0));
  CHECK(pid.a(false) == Approx(0.48 + 10.0));
  CHECK(pid.b() == Approx(0.48 + 20.0));
  CHECK(pid.c() == Approx(10.0));

  PidParams other = PidParams::from_gains(1.5, 0.25, 3.0, 0.5);
  const IncrementalPid pid2{other};
  const double t = 0.5;
  CHECK(pid2.a(true) == Approx(1.5 * (1.0 + t / other.ti_s + other.td_s / t)));
  CHECK(pid2.b() == Approx(1.5 * (1.0 + 2.0 * other.td_s / t)));
  CHECK(pid2.c() == Approx(1.5 * other.td_s / t));
}

TEST_CASE("a casing colder than the setpoint drives the output positive (heating)") {
  IncrementalPid pid{PidParams{}};
  CHECK(pid.step(16.0, 55.0) > 0.0);
  IncrementalPid hot{PidParams{}};
  CHECK(hot.step(60.0, 55.0) < 0.0);
}

TEST_CASE("the increment equals Eq. 17 applied with the heating sign") {
  IncrementalPid pid{unsaturated_params()};
  const std::vector<double> temps{54.8, 54.7, 54.9, 55.2, 55.1};
  double u = pid.step(temps[0], 55.0);
  double e2 = temps[0] - 55.0;  // bumpless start: history equals the first error
  double e1 = e2;
  for (std::size_t k = 1; k < temps.size(); ++k) {
    const double e = temps[k] - 55.0;
    const double expected = u - (pid.a(true) * e - pid.b() * e1 + pid.c() * e2);
    u = pid.step(temps[k], 55.0);
    CHECK(u == Approx(expected).margin(1e-12));
    e2 = e1;
    e1 = e;
  }
}

TEST_CASE("the integral term works only inside the band |e| < xi") {
  IncrementalPid pid{unsaturated_params()};
  pid.step(50.0, 55.0);  // |e| = 5 > 0.5: PD
  CHECK_FALSE(pid.integrating());
  // A constant error outside the band leaves the output constant (PD only).
  const double held = pid.step(50.0, 55.0);
  CHECK(pid.step(50.0, 55.0) == Approx(held));
  CHECK_FALSE(pid.integrating());

  IncrementalPid inside{unsaturated_params()};
  inside.step(54.625, 55.0);  // |e| = 0.375 < xi: PID
  CHECK(inside.integrating());
  const double u1 = inside.step(54.625, 55.0);
  const double u2 = inside.step(54.625, 55.0);
  // Constant error inside the band: each step adds KI * |e| of heating.
  CHECK(u2 - u1 == Approx(0.32 * 0.375));
}

TEST_CASE("an error of exactly xi is PD, as the seed's prototype runs it (|e| >= 0.5 C)") {
  // 54.5 C is a reading the DS18B20's 1/16 C steps give: |e| = 0.5 exactly.
  IncrementalPid pid{unsaturated_params()};
  const double u1 = pid.step(54.5, 55.0);
  CHECK_FALSE(pid.integrating());
  CHECK(pid.step(54.5, 55.0) == Approx(u1));
  IncrementalPid below{unsaturated_params()};
  below.step(54.5625, 55.0);  // one step closer: PID
  CHECK(below.integrating());
}

TEST_CASE("the incremental form equals a positional PID while unsaturated") {
  const PidParams p = unsaturated_params();
  IncrementalPid pid{p};
  pid.reset(0.7);
  // Positional integral-separated PID with the same sign convention:
  // u = -(Kp e + KD (e - e_prev)) + I,  I -= beta KI e.
  double integral = 0.7;
  double e_prev = 0.0;
  bool first = true;
  for (int k = 0; k < 200; ++k) {
    const double measured = 55.0 + 1.2 * std::sin(0.07 * k) * std::exp(-0.01 * k) +
                            0.03 * std::cos(1.3 * k);
    const double e = measured - 55.0;
    if (first) e_prev = e;
    first = false;
    if (std::fabs(e) < p.xi_c) integral -= p.ki() * e;
    const double positional = -(p.kp * e + p.kd() * (e - e_prev)) + integral;
    e_prev = e;
    REQUIRE(pid.step(measured, 55.0) == Approx(positional).margin(1e-9));
    REQUIRE_FALSE(pid.saturated());
  }
}

TEST_CASE("bumpless start: no derivative kick, output continues from reset value at zero error") {
  IncrementalPid pid{PidParams{}};
  pid.reset(1.25);
  CHECK(pid.output() == Approx(1.25));
  CHECK(pid.step(55.0, 55.0) == Approx(1.25));
  CHECK(pid.step(55.0, 55.0) == Approx(1.25));

  // A first error of 0.3 C gives the proportional and integral part only, not
  // the KD * 0.3 = 3 A derivative kick.
  IncrementalPid fresh{PidParams{}};
  CHECK(fresh.step(54.7, 55.0) == Approx(0.48 * 0.3 + 0.32 * 0.3));
}

TEST_CASE("the integral is the output less its proportional and derivative parts") {
  IncrementalPid pid{PidParams{}};
  CHECK(pid.integral() == 0.0);
  pid.reset(0.3);
  CHECK(pid.integral() == Approx(0.3));  // before a step: the reset value
  pid.step(54.8, 55.0);                  // in the band: P + I step
  pid.step(54.9, 55.0);
  const double kd = PidParams{}.kd();
  // v = -(Kp e + KD (e(k) - e(k-1))) + I with e = -0.1, e(k-1) = -0.2.
  CHECK(pid.integral() == Approx(pid.output() + 0.48 * -0.1 + kd * (-0.1 + 0.2)).margin(1e-12));
  CHECK(pid.integral() == Approx(0.3 + 0.32 * 0.2 + 0.32 * 0.1).margin(1e-12));  // the two integral steps
}

TEST_CASE("a restart from the integral answers an error that grew while stopped with its proportional part") {
  // Held at 55 C with 0.2 A of integral; the TEC went off and the casing
  // fell to 52 C. Restarted from the integral, the PD heats with Kp * 3 C
  // more; restarted from the whole output it would hold 0.2 A at 52 C, and
  // outside the band nothing would ever move it.
  IncrementalPid pid{PidParams{}};
  pid.reset(0.2);
  pid.step(55.0, 55.0);
  const double integral = pid.integral();
  CHECK(integral == Approx(0.2));
  IncrementalPid restarted{PidParams{}};
  restarted.reset(integral);
  CHECK(restarted.step(52.0, 55.0) == Approx(0.2 + 0.48 * 3.0).margin(1e-12));
}

TEST_CASE("output stays within the limits and reports saturation") {
  IncrementalPid pid{PidParams{}};
  CHECK(pid.step(16.0, 55.0) == Approx(2.0));
  CHECK(pid.saturated());
  CHECK(pid.step(90.0, 55.0) == Approx(-2.0));
  CHECK(pid.saturated());
}

TEST_CASE("a large setpoint step keeps heating at the limit until the proportional band") {
  // Warm up at 0.02 C per period from 16 C: the output must stay at the rail
  // while Kp |e| - KD * 0.02 > out_max, i.e. up to about 50 C (a velocity form
  // that clamped its own state would fall off the rail after a few degrees).
  IncrementalPid pid{PidParams{}};
  for (double t = 16.0; t < 45.0; t += 0.02) {
    REQUIRE(pid.step(t, 55.0) == Approx(2.0));
  }
}

TEST_CASE("saturation inside the band does not wind up the integral") {
  PidParams p;
  p.out_min = -0.1;
  p.out_max = 0.1;
  IncrementalPid pid{p};
  // 0.4 C too cold inside the band for a long time: the output sits at the limit.
  for (int k = 0; k < 500; ++k) pid.step(54.6, 55.0);
  CHECK(pid.output() == Approx(0.1));
  // Once slightly too hot, the output must leave the heating limit at once
  // (a wound-up integral of 500 * 0.128 A would keep it there for hundreds of steps).
  pid.step(55.05, 55.0);
  pid.step(55.05, 55.0);
  CHECK(pid.output() < 0.1);
}

TEST_CASE("a non-finite measurement leaves output and state unchanged") {
  IncrementalPid pid{PidParams{}};
  pid.step(54.8, 55.0);
  const double before = pid.output();
  CHECK(pid.step(std::nan(""), 55.0) == Approx(before));
  CHECK(pid.step(INFINITY, 55.0) == Approx(before));
  IncrementalPid twin{PidParams{}};
  twin.step(54.8, 55.0);
  CHECK(pid.step(54.9, 55.0) == Approx(twin.step(54.9, 55.0)));
}

TEST_CASE("invalid parameters are rejected naming the field") {
  PidParams p;
  p.ti_s = 0.0;
  CHECK_THROWS_WITH(IncrementalPid{p}, Catch::Contains("ti_s"));
  PidParams q;
  q.out_min = 3.0;
  CHECK_THROWS_WITH(IncrementalPid{q}, Catch::Contains("out_min"));
}

TEST_CASE("limits given for a step bound the output, and the integral stops at them") {
  PidParams p = PidParams::from_gains(0.2, 0.05, 0.0, 2.0);  // PI: no derivative kick hides a windup
  p.xi_c = 1.0;
  IncrementalPid pid{p};
  // Inside the band, too cold: the output would climb by KI * 0.4 every step.
  double out = 0.0;
  for (int k = 0; k < 200; ++k) out = pid.step(54.6, 55.0, -0.2, 0.3);
  CHECK(out == Approx(0.3));
  CHECK(pid.saturated());
  // The limits of the parameters (2 A) would have let it wind up to 2 A, and
  // the output would stay at 0.3 A for ~100 steps; with the step's limits it
  // comes off as soon as the error turns.
  out = pid.step(55.0625, 55.0, -0.2, 0.3);
  out = pid.step(55.0625, 55.0, -0.2, 0.3);
  CHECK(out < 0.3);
}

TEST_CASE("retuning in a steady hold moves the output only by the new gains' integral step, no kick") {
  PidParams p = unsaturated_params();
  IncrementalPid pid(p);
  for (int k = 0; k < 20; ++k) pid.step(54.8, 55.0);  // a steady error of -0.2 C, in the integral band
  const double before = pid.output();
  PidParams doubled = PidParams::from_gains(2 * p.kp, 2 * p.ki(), 2 * p.kd(), p.period_s);
  doubled.out_min = p.out_min;
  doubled.out_max = p.out_max;
  pid.retune(doubled);
  CHECK(pid.output() == before);
  // With e(k) = e(k-1) = e(k-2) the velocity form's increment is -KI e: the new KI's.
  CHECK(pid.step(54.8, 55.0) - before == Approx(2 * p.ki() * 0.2));
}

TEST_CASE("retuning to narrower limits clamps the output at once") {
  PidParams p;
  IncrementalPid pid(p);
  for (int k = 0; k < 5; ++k) pid.step(20.0, 55.0);  // far below: the output at out_max
  REQUIRE(pid.output() == p.out_max);
  PidParams narrow = p;
  narrow.out_max = 0.5;
  pid.retune(narrow);
  CHECK(pid.output() == 0.5);
  CHECK(pid.step(20.0, 55.0) == 0.5);
}
