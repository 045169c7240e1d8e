#pragma once

#include <string>
#include <string_view>

#include "gyrotc/algorithms/model/plant.hpp"

namespace gyrotc::app {

// Plant description file (TOML), versions 1 and 2; docs/PLANT.md is the
// reference. Every key is optional (the documented default of
// model::PlantParams applies) unless a [network] needs it; unknown keys are
// errors.
//   format = "gyrotc-plant", version = 1 or 2 (2 with [network])
//   [thermal]     shell_capacity_j_per_k, casing_capacity_j_per_k, die_capacity_j_per_k,
//                 shell_ambient_w_per_k, shell_casing_leak_w_per_k, casing_die_w_per_k,
//                 internal_power_w
//   [tec]         seebeck_v_per_k, resistance_ohm, conductance_w_per_k
//   [stage]       dac_vref_v, dac_bits, gain_a_per_v, current_limit_a, supply_pos_v,
//                 supply_neg_v, rail_headroom_v, opa548_theta_ja_c_per_w,
//                 opa548_thermal_tau_s, opa548_shutdown_c, opa548_restart_c
//   [sensors]     ds18b20_offset_c, adc_noise_uv
//   [gyro]        scale_mv_per_dps, arw_deg_per_sqrt_h, bias_instability_dps,
//                 bias_instability_tau_s, zero_rate_offset_mv,
//                 zero_bias_c = [...], zero_bias_mv = [...] (the zero-rate output at
//                 the die temperature, a natural cubic spline through the points;
//                 both or neither; default: the seed's Table 2)
//   [integration] max_thermal_step_s, initial_temp_c
//   [network]     version 2: the user's own lumped network, instead of [thermal]
//                 and sensors.ds18b20_offset_c (model/thermal_network.hpp):
//                 nodes.NAME = J/K; [[links]] between = [A, B], w_per_k;
//                 tec.between = [FROM, TO]; heat_w.NAME = W;
//                 sensors.casing / sensors.ambient {node, tau_s, offset_c, noise_c};
//                 gyro.node
//   [effects.<name>] the named effects (model/effects.hpp), on when present:
//     thermal_lag {tau_s}, rate_sensitivity {k_mv_per_c_per_s},
//     ramp_hysteresis {h_mv, r0_c_per_s}, warm_up {a_mv, tau_s},
//     linear_drift {d_mv_per_h}, tec_joule_heating {r_ohm}
// Errors are InputErrors naming the file, the line and the key.
model::PlantParams load_plant(const std::string& path);
model::PlantParams parse_plant(std::string_view text, const std::string& name);

// The file's text for params (every key written, the zero-bias curve when it
// is not Table 2, version 2 and [network] for a network plant; numbers read
// back exactly).
std::string format_plant(const model::PlantParams& params);
// RuntimeFailure when the file cannot be written.
void save_plant(const model::PlantParams& params, const std::string& path);

}  // namespace gyrotc::app
