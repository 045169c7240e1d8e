#include <cstdlib>
#include <filesystem>
#include <string>

#include "gyrotc/app/data_dir.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::data_dir;

TEST_CASE("GYROTC_DATA_DIR in the environment overrides where the seed's data is read from") {
  ::setenv("GYROTC_DATA_DIR", "/opt/site/gyrotc-data", 1);
  CHECK(data_dir() == "/opt/site/gyrotc-data");
  ::unsetenv("GYROTC_DATA_DIR");
}

TEST_CASE("a build-tree run reads the source tree's data directory") {
  ::unsetenv("GYROTC_DATA_DIR");
  CHECK(std::filesystem::equivalent(data_dir(), GYROTC_DATA_DIR));
  CHECK(std::filesystem::exists(data_dir() + "/fig26_chamber_profile.csv"));
}
