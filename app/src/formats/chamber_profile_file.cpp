#include "gyrotc/app/formats/chamber_profile_file.hpp"

#include <stdexcept>
#include <utility>
#include <vector>

#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

model::ChamberProfile load_chamber_profile(const std::string& path) {
  const CsvTable table = CsvTable::read(path);
  std::vector<model::ProfileSegment> segments;
  if (table.has("segment")) {
    const auto names = table.text("segment");
    const auto start = table.numbers("start_s");
    const auto end = table.numbers("end_s");
    const auto a0 = table.numbers("ambient_start_c");
    const auto a1 = table.numbers("ambient_end_c");
    for (std::size_t i = 0; i < names.size(); ++i) {
      segments.push_back({names[i], start[i], end[i], a0[i], a1[i]});
    }
  } else if (table.has("time_s") && table.has("ambient_c")) {
    table.require_increasing("time_s");
    const auto t = table.numbers("time_s");
    const auto a = table.numbers("ambient_c");
    if (t.size() < 2) throw InputError(path + ": a points profile needs at least two rows");
    for (std::size_t i = 0; i + 1 < t.size(); ++i) {
      segments.push_back({"t=" + std::to_string(static_cast<long long>(t[i])), t[i], t[i + 1], a[i],
                          a[i + 1]});
    }
  } else {
    throw InputError(path +
                     ": a chamber profile needs columns segment,start_s,end_s,ambient_start_c,"
                     "ambient_end_c or time_s,ambient_c");
  }
  try {
    return model::ChamberProfile(std::move(segments));
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
}

model::ChamberProfile chamber_profile_by_name(const std::string& name_or_path,
                                              const std::string& data_dir) {
  if (name_or_path == "table2") return model::ChamberProfile::table2();
  if (name_or_path == "fig26") return load_chamber_profile(data_dir + "/fig26_chamber_profile.csv");
  return load_chamber_profile(name_or_path);
}

}  // namespace gyrotc::app
