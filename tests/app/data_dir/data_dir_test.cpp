#include <cstdlib>
#include <filesystem>
#include <string>

#include "gyrotc/app/support/data_dir.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using gyrotc::app::data_dir;
using gyrotc::app::executable_dir;

TEST_CASE("GYROTC_DATA_DIR in the environment overrides where the seed's data is read from") {
  ::setenv("GYROTC_DATA_DIR", "/opt/site/gyrotc-data", 1);
  CHECK(data_dir() == "/opt/site/gyrotc-data");
  ::unsetenv("GYROTC_DATA_DIR");
}

TEST_CASE("the data folder is found from the executable's own folder, as in an install prefix") {
  ::unsetenv("GYROTC_DATA_DIR");
  CHECK(std::filesystem::equivalent(executable_dir(), gyrotc::test::root() + "/tests"));
  // bin/../share/gyrotc: build/<preset>/share/gyrotc in a build, /usr/share/gyrotc installed.
  CHECK(std::filesystem::equivalent(data_dir(), gyrotc::test::root() + "/share/gyrotc"));
  CHECK(std::filesystem::exists(data_dir() + "/fig26_chamber_profile.csv"));
}
