#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

// CLI11 is declared, not included: its header costs ~10 s of compile per
// translation unit (30 s under the sanitizers), and the tests that run a
// command through tests/support/run_command.hpp need only the name.
namespace CLI {
class App;
}  // namespace CLI

// Every `gyrotc <command>` registers itself through one of these;
// add_gyrotc_commands() calls them in the order of --help. Each callback
// throws InputError / RuntimeFailure for main() to report.
namespace gyrotc::app {

// The whole `gyrotc` command line: its description, --version and every
// command below, as main() runs it (and the CLI's tests check it).
void add_gyrotc_commands(CLI::App& cli);

void add_identify_command(CLI::App& app);
void add_probe_command(CLI::App& app);
void add_fit_command(CLI::App& app);
void add_calibrate_command(CLI::App& app);

// `gyrotc fit --data RECORD --die-lag-s LAG --method auto --out OUT [--plot PLOT] [--json]`,
// for `gyrotc calibrate`: the same refusals, fit, report and file;
// extra_json's keys join the --json summary. die_lag_s_std > 0: the lag was
// measured with that standard error, and the calibration's error bound draws
// each replicate's lag from it.
void fit_record_auto(const std::string& data, double die_lag_s, double die_lag_s_std, const std::string& out,
                     const std::string& plot, bool json, const nlohmann::json& extra_json);
void add_simulate_command(CLI::App& app);
void add_tune_command(CLI::App& app);
void add_allan_command(CLI::App& app);
void add_run_command(CLI::App& app);
void add_record_command(CLI::App& app);
void add_safe_off_command(CLI::App& app);
void add_check_config_command(CLI::App& app);
void add_status_command(CLI::App& app);

}  // namespace gyrotc::app
