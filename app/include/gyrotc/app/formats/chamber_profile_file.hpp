#pragma once

#include <string>

#include "gyrotc/algorithms/model/chamber_profile.hpp"

namespace gyrotc::app {

// A chamber profile from a CSV file, either
//  - segments: columns segment, start_s, end_s, ambient_start_c, ambient_end_c
//    (data/fig26_chamber_profile.csv), or
//  - points: columns time_s, ambient_c (strictly increasing time; linear
//    interpolation between the points, each interval a segment "t=<time>").
// Errors are InputErrors naming the file and line.
model::ChamberProfile load_chamber_profile(const std::string& path);

// "fig26" (fig26_chamber_profile.csv of data_dir, normally data_dir() of
// data_dir.hpp), "table2" (ChamberProfile::table2()), or a CSV path as above.
model::ChamberProfile chamber_profile_by_name(const std::string& name_or_path, const std::string& data_dir);

}  // namespace gyrotc::app
