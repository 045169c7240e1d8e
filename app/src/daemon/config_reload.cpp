#include "gyrotc/app/daemon/config_reload.hpp"

#include <algorithm>
#include <iterator>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

void collect(const toml::table* before, const toml::table* after, const std::string& prefix,
             std::vector<std::string>& out) {
  static const toml::table kEmpty;
  const toml::table& b = before != nullptr ? *before : kEmpty;
  const toml::table& a = after != nullptr ? *after : kEmpty;
  const auto visit = [&](std::string_view key) {
    const toml::node* nb = b.get(key);
    const toml::node* na = a.get(key);
    const std::string path = prefix.empty() ? std::string(key) : prefix + "." + std::string(key);
    if ((nb != nullptr && nb->is_table()) || (na != nullptr && na->is_table())) {
      collect(nb != nullptr ? nb->as_table() : nullptr, na != nullptr ? na->as_table() : nullptr, path, out);
      return;
    }
    using view = toml::node_view<const toml::node>;
    const bool same = nb != nullptr && na != nullptr && view(nb) == view(na);
    if (!same && std::find(out.begin(), out.end(), path) == out.end()) out.push_back(path);
  };
  for (auto&& [key, node] : a) visit(key.str());
  for (auto&& [key, node] : b) {
    if (!a.contains(key.str())) visit(key.str());
  }
}

}  // namespace

std::vector<std::string> changed_keys(const toml::table& before, const toml::table& after) {
  std::vector<std::string> out;
  collect(&before, &after, "", out);
  return out;
}

bool reloadable_key(std::string_view key) {
  static constexpr std::string_view kReloadable[] = {"control.setpoint_c",
                                                     "control.kp",
                                                     "control.ki",
                                                     "control.kd",
                                                     "control.period_s",
                                                     "control.xi_c",
                                                     "control.out_min_a",
                                                     "control.out_max_a",
                                                     "control.pid",
                                                     "control.feed_forward_a_per_c",
                                                     "control.feed_forward_lag_s",
                                                     "control.setpoint_ramp_c_per_s",
                                                     "control.controller_file",
                                                     "calibration.file",
                                                     "output.status_interval_s",
                                                     "output.stream",
                                                     "output.path",
                                                     "output.baud",
                                                     "output.record_csv",
                                                     "output.record_max_mb",
                                                     "output.write_timeout_s",
                                                     "output.status_file",
                                                     "output.metrics_file"};
  return std::find(std::begin(kReloadable), std::end(kReloadable), key) != std::end(kReloadable);
}

ReloadPlan plan_reload(const SessionOptions& options, const toml::table& running) {
  ReloadPlan plan;
  plan.config = load_daemon_config(options.config_path);
  if (!options.controller_file.empty()) use_controller_file(plan.config, options.controller_file);
  if (options.pid) plan.config.controller.pid_enabled = *options.pid;
  plan.calibration = load_calibration_in_use(plan.config.calibration_file);
  toml::table now;
  try {
    now = toml::parse_file(options.config_path);
  } catch (const toml::parse_error& e) {  // changed again since load_daemon_config read it
    throw InputError(options.config_path + ":" + std::to_string(e.source().begin.line) + ": " +
                     std::string(e.description()));
  }
  for (const std::string& key : changed_keys(running, now)) {
    if (!reloadable_key(key)) plan.restart_keys.push_back(key);
  }
  return plan;
}

}  // namespace gyrotc::app
