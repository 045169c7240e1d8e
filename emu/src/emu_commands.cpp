#include "gyrotc/emu/emu_commands.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/emu/control_socket.hpp"
#include "gyrotc/emu/hil_report.hpp"
#include "gyrotc/hal/chips/ad5060.hpp"

namespace gyrotc::emu {

namespace {

double after_mark(const std::vector<LogEvent>& events, const std::string& mark, const std::string& log) {
  if (mark.empty()) return -INFINITY;
  const std::optional<double> t = mark_time(events, mark);
  if (!t) throw app::InputError(log + ": no mark \"" + mark + "\" in the log (gyrotc-emu ctl mark " + mark + ")");
  return *t;
}

// The TEC DAC code of 0 A: mid-scale of its reference (TecStage: I = (V - Vref/2) * gain).
unsigned zero_amp_code(const app::DaemonConfig& c) {
  const double vref = c.board.devices.tec_dac.vref_v;
  return hal::Ad5060::code_for_v(0.5 * vref, vref);
}

[[noreturn]] void verdict(bool pass) { throw app::CommandExit(pass ? 0 : 1); }

}  // namespace

void add_ctl_command(CLI::App& app) {
  auto socket = std::make_shared<std::string>(kDefaultControlSocket);
  auto words = std::make_shared<std::vector<std::string>>();
  CLI::App* cmd = app.add_subcommand(
      "ctl",
      "Send one command to a running `gyrotc-emu run` and print its answer (exit 0 on \"ok\", 1 on an error).\n"
      "Commands:\n"
      "  status                              the true plant and board state, one line of key=value\n"
      "  fault casing|ambient FAULT          FAULT: none, disconnect (unplugged), crc (every read fails its\n"
      "                                      CRC), stuck, power-on-reset (85 C once), all-zero, low-resolution\n"
      "  fault drdy-stall on|off             the ADS1251's DRDY stays high\n"
      "  fault spi-error adc|rate_dac|tec_dac on|off   the SPI controller fails every transfer (EIO)\n"
      "  fault opa548-shutdown on|off        the OPA548 in thermal shutdown (it pulls E/S low)\n"
      "  ambient C [C_PER_S]                 the chamber's temperature, optionally ramping\n"
      "  chamber PROFILE.csv                 a chamber profile (as gyrotc simulate --profile) from now\n"
      "  rate DEG_PER_S                      the true angular rate\n"
      "  mark TEXT                           a marker in the event log (for `gyrotc-emu report`)");
  cmd->add_option("--control", *socket, "the emulator's control socket")->capture_default_str();
  cmd->add_option("command", *words, "the command and its arguments")->required();
  cmd->callback([socket, words] {
    std::string line;
    for (const std::string& w : *words) line += (line.empty() ? "" : " ") + w;
    const std::string reply = control_request(*socket, line);
    if (reply.rfind("ok", 0) == 0) {
      std::printf("%s\n", reply.c_str());
      return;
    }
    std::fprintf(stderr, "gyrotc-emu: %s\n", reply.c_str());
    throw app::CommandExit(1);
  });
}

void add_report_command(CLI::App& app) {
  CLI::App* report = app.add_subcommand(
      "report",
      "Questions to an emulator's event log (gyrotc-emu run --log): what the hardware saw the daemon do.\n"
      "Each prints one line and exits 0 when the answer is yes, 1 when it is no.");
  report->require_subcommand(1);

  struct Common {
    std::string log, mark, until_mark;
  };
  auto add_common = [](CLI::App* sub, Common& c) {
    sub->add_option("--log", c.log, "the event log (gyrotc-emu run --log)")->required();
    sub->add_option("--after-mark", c.mark, "only events after the last mark of this text (gyrotc-emu ctl mark)");
  };

  {
    auto c = std::make_shared<Common>();
    auto setpoint = std::make_shared<double>(55.0);
    auto band = std::make_shared<double>(0.3);
    auto hold = std::make_shared<double>(60.0);
    CLI::App* sub = report->add_subcommand(
        "settle", "Did the true casing temperature stay within --band of --setpoint for --hold seconds?");
    add_common(sub, *c);
    sub->add_option("--setpoint", *setpoint, "setpoint, C")->capture_default_str();
    sub->add_option("--band", *band, "band, +/- C")->capture_default_str()->check(app::positive_number());
    sub->add_option("--hold", *hold, "seconds inside the band")->capture_default_str()->check(app::positive_number());
    sub->callback([c, setpoint, band, hold] {
      const auto events = read_event_log(c->log);
      const SettleResult r = find_settle(events, *setpoint, *band, *hold, after_mark(events, c->mark, c->log));
      if (r.settled) {
        std::printf("settled: true casing within %.2f C of %.2f C for %.0f s from t=%.1f s (max |error| %.3f C)\n",
                    *band, *setpoint, *hold, r.settled_at_s, r.max_abs_error_c);
      } else {
        std::printf("not settled: longest stretch within %.2f C of %.2f C was %.1f s (max |error| %.3f C); "
                    "%zu plant samples, last error %+.3f C\n",
                    *band, *setpoint, r.longest_hold_s, r.max_abs_error_c, r.samples, r.last_error_c);
      }
      verdict(r.settled);
    });
  }
  {
    auto c = std::make_shared<Common>();
    auto record = std::make_shared<std::string>();
    auto config = std::make_shared<std::string>();
    auto max_lsb = std::make_shared<double>(1.0);
    auto max_mean = std::make_shared<double>(0.05);
    auto true_rate = std::make_shared<double>(0.0);
    auto mean_mark = std::make_shared<std::string>();
    CLI::App* sub = report->add_subcommand(
        "compensation",
        "Do the rate-DAC codes the hardware latched, averaged over each record period, equal the compensated\n"
        "rate of the daemon's record (within --max-lsb rate-DAC LSBs), and is their mean within --max-mean of\n"
        "the true rate?");
    add_common(sub, *c);
    sub->add_option("--until-mark", c->until_mark, "only events before this mark");
    sub->add_option("--mean-after-mark", *mean_mark,
                    "the mean latched rate from this mark on (default: from --after-mark on)");
    sub->add_option("--record", *record, "the daemon's record (gyrotc run/record CSV)")->required();
    sub->add_option("--config", *config, "the daemon's configuration (rate DAC reference and scale)")->required();
    sub->add_option("--max-lsb", *max_lsb, "largest difference of a period's mean, in LSBs")->capture_default_str();
    sub->add_option("--max-mean", *max_mean, "largest |mean - true rate|, deg/s")->capture_default_str();
    sub->add_option("--true-rate", *true_rate, "the true rate the emulator applied, deg/s")->capture_default_str();
    sub->callback([c, record, config, max_lsb, max_mean, true_rate, mean_mark] {
      const app::DaemonConfig dc = app::load_daemon_config(*config);
      const auto events = read_event_log(c->log);
      const double after = after_mark(events, c->mark, c->log);
      const double until = c->until_mark.empty() ? INFINITY : after_mark(events, c->until_mark, c->log);
      const DacScale scale{dc.board.devices.rate_dac.vref_v, dc.controller.rate_out_v_per_dps};
      const double mean_from = mean_mark->empty() ? after : after_mark(events, *mean_mark, c->log);
      const CompensationResult r = compare_compensation(events, read_record(*record), scale, after, until, mean_from);
      const bool pass = r.max_diff_lsb <= *max_lsb && std::fabs(r.mean_rate_dps - *true_rate) <= *max_mean;
      std::printf("%s: %zu record periods, %zu rate-DAC frames: worst period mean %.2f LSB from the record "
                  "(t=%.0f s; 1 LSB = %.4f deg/s); mean latched rate %+.4f deg/s over %zu frames (true %+.4f, "
                  "limit %.3f)\n",
                  pass ? "match" : "mismatch", r.rows, r.frames, r.max_diff_lsb, r.worst_row_time_s, r.lsb_dps,
                  r.mean_rate_dps, r.mean_frames, *true_rate, *max_mean);
      verdict(pass);
    });
  }
  {
    auto c = std::make_shared<Common>();
    auto config = std::make_shared<std::string>();
    auto expect = std::make_shared<double>(0.0);
    auto within = std::make_shared<double>(INFINITY);
    CLI::App* sub = report->add_subcommand(
        "rate", "The mean rate the rate DAC latched between two marks, and is it within --within of --expect?");
    add_common(sub, *c);
    sub->add_option("--until-mark", c->until_mark, "only events before this mark")->required();
    sub->add_option("--config", *config, "the daemon's configuration (rate DAC reference and scale)")->required();
    sub->add_option("--expect", *expect, "the rate expected, deg/s")->capture_default_str();
    sub->add_option("--within", *within, "the largest |mean - expected| that passes, deg/s");
    sub->callback([c, config, expect, within] {
      const app::DaemonConfig dc = app::load_daemon_config(*config);
      const auto events = read_event_log(c->log);
      const double after = after_mark(events, c->mark, c->log);
      const double until = after_mark(events, c->until_mark, c->log);
      const DacScale scale{dc.board.devices.rate_dac.vref_v, dc.controller.rate_out_v_per_dps};
      double sum = 0.0;
      std::size_t n = 0;
      for (const LogEvent& e : events) {
        if (e.kind != "dac" || e.device != "rate_dac" || e.detail.rfind("mode=normal", 0) != 0 || e.t_s < after ||
            e.t_s > until) {
          continue;
        }
        sum += scale.rate_of(static_cast<unsigned>(std::stoul(e.value)));
        ++n;
      }
      if (n == 0) throw app::InputError(c->log + ": no rate-DAC frame between the marks");
      const double mean = sum / static_cast<double>(n);
      const bool pass = std::fabs(mean - *expect) <= *within;
      std::printf("%s: mean latched rate %+.4f deg/s over %zu frames (%.1f s); expected %+.4f within %.3f\n",
                  pass ? "as expected" : "not as expected", mean, n, until - after, *expect, *within);
      verdict(pass);
    });
  }
  {
    auto c = std::make_shared<Common>();
    auto config = std::make_shared<std::string>();
    auto within = std::make_shared<double>(INFINITY);
    auto resume = std::make_shared<double>(-1.0);
    auto from_event = std::make_shared<std::string>();
    auto es_only = std::make_shared<bool>(false);
    CLI::App* sub = report->add_subcommand(
        "safe",
        "When, after the mark, was the TEC path safe (TEC DAC at the 0 A code and E/S low), and did it\n"
        "drive again afterwards?");
    add_common(sub, *c);
    sub->add_option("--config", *config, "the daemon's configuration (the TEC DAC's 0 A code)")->required();
    sub->add_option("--within", *within, "seconds after the mark the TEC path must be safe by");
    sub->add_option("--resume-within", *resume, "and must drive again within these seconds after it was safe");
    sub->add_option("--from-event", *from_event,
                    "KIND:DEVICE (e.g. fault:casing_sensor): count from the first such event after the mark "
                    "instead of the mark itself");
    sub->add_flag("--es-only", *es_only,
                  "E/S low alone counts as safe (the TEC DAC refuses every frame, an SPI error on it, and keeps its "
                  "last code)");
    sub->callback([c, config, within, resume, from_event, es_only] {
      const app::DaemonConfig dc = app::load_daemon_config(*config);
      const auto events = read_event_log(c->log);
      double after = after_mark(events, c->mark, c->log);
      if (!from_event->empty()) {
        const std::size_t colon = from_event->find(':');
        const std::string kind = from_event->substr(0, colon);
        const std::string device = colon == std::string::npos ? "" : from_event->substr(colon + 1);
        const auto e = std::find_if(events.begin(), events.end(), [&](const LogEvent& x) {
          return x.t_s >= after && x.kind == kind && (device.empty() || x.device == device);
        });
        if (e == events.end()) throw app::InputError(c->log + ": no " + *from_event + " event after the mark");
        after = e->t_s;
      }
      const unsigned zero = zero_amp_code(dc);
      const SafeResult r = find_safe(events, zero, after);
      const auto rel = [&](const std::optional<double>& t) -> std::string {
        if (!t) return "never";
        char text[32];
        std::snprintf(text, sizeof text, "%.2f s", *t - after);
        return text;
      };
      const std::optional<double> safe_s = *es_only ? r.es_low_s : r.safe_s;
      const std::optional<double> resumed_s = *es_only ? r.es_resumed_s : r.resumed_s;
      bool pass = safe_s && *safe_s - after <= *within;
      if (*resume >= 0.0) pass = pass && resumed_s && *resumed_s - *safe_s <= *resume;
      std::printf("%s: TEC DAC at the 0 A code (%u) after %s (written by pid %d), E/S low after %s, %s after %s; "
                  "driving again after %s\n",
                  pass ? "safe" : "not safe in time", zero, rel(r.tec_zero_s).c_str(), r.tec_zero_pid,
                  rel(r.es_low_s).c_str(), *es_only ? "safe (E/S alone)" : "both", rel(safe_s).c_str(),
                  rel(resumed_s).c_str());
      verdict(pass);
    });
  }
}

}  // namespace gyrotc::emu
