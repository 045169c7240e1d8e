#include <stdexcept>

#include "gyrotc/algorithms/model/chamber_profile.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::model::ChamberProfile;
using gyrotc::model::ProfileSegment;

TEST_CASE("a chamber profile interpolates linearly inside ramps and holds at the ends") {
  ChamberProfile profile({{"hold", 0.0, 100.0, 16.0, 16.0}, {"ramp", 100.0, 700.0, 16.0, 6.0}});
  CHECK(profile.ambient_c(-5.0) == 16.0);
  CHECK(profile.ambient_c(50.0) == 16.0);
  CHECK(profile.ambient_c(400.0) == Approx(11.0));
  CHECK(profile.ambient_c(1000.0) == 6.0);
  CHECK(profile.ambient_c(160.0) == Approx(15.0));  // out-of-order queries work too
  CHECK(profile.segment_at(400.0) == 1);
}

TEST_CASE("a chamber profile with a gap between segments is rejected naming the segment") {
  CHECK_THROWS_WITH(ChamberProfile({{"a", 0.0, 10.0, 0.0, 0.0}, {"b", 20.0, 30.0, 0.0, 0.0}}),
                    Catch::Contains("'b'"));
}

TEST_CASE("the table2 profile soaks 60 minutes at every Table 2 temperature from -40 to 80 C") {
  const ChamberProfile profile = ChamberProfile::table2();
  int soaks = 0;
  for (const auto& s : profile.segments()) {
    if (s.is_hold()) {
      ++soaks;
      CHECK(s.end_s - s.start_s == 3600.0);
    }
  }
  CHECK(soaks == 25);
  CHECK(profile.ambient_c(0.0) == -40.0);
  CHECK(profile.ambient_c(profile.end_s()) == 80.0);
}
