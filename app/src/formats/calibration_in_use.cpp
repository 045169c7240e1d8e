#include "gyrotc/app/formats/calibration_in_use.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "gyrotc/app/formats/calibration_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/sha256.hpp"

namespace gyrotc::app {

CalibrationInUse load_calibration_in_use(const std::string& file) {
  CalibrationInUse c;
  if (file.empty()) return c;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file + ": cannot open the calibration file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(file + ": read error");
  Calibration parsed = parse_calibration(text.str(), file);
  c.file = file;
  c.model = std::move(parsed.model);
  c.scale_mv_per_dps = parsed.scale_mv_per_dps;
  c.die_lag_s = parsed.die_lag_s;
  c.bound = std::move(parsed.bound);
  c.sha256 = sha256_hex(text.str());
  return c;
}

std::string describe(const CalibrationInUse& c) {
  char range[64];
  std::snprintf(range, sizeof range, "%g..%g C", c.model.t_min_c(), c.model.t_max_c());
  std::string what = std::string(c.model.kind_name()) + ", " + range;
  if (c.die_lag_s > 0.0) {
    char die[64];
    std::snprintf(die, sizeof die, " of the die, %.1f s behind the sensor", c.die_lag_s);
    what += die;
  }
  if (c.bound) {
    char bound[96];
    std::snprintf(bound, sizeof bound, ", error <= %.4f deg/s (%.0f %%) over %.1f..%.1f C", c.bound->range_dps,
                  100.0 * c.bound->confidence, c.bound->lo_c(), c.bound->hi_c());
    what += bound;
  }
  if (c.file.empty()) return "the seed's built-in reference model (" + what + ")";
  return c.file + ": " + what + ", sha256 " + c.sha256.substr(0, 16);
}

}  // namespace gyrotc::app
