// Which calibration a configuration runs with: loaded as the daemon loads it,
// described as probe and the daemon's log print it.
#include "gyrotc/app/formats/calibration_in_use.hpp"

#include <fstream>
#include <string>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/sha256.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc::app;

TEST_CASE("SHA-256 gives the FIPS 180-2 digests of the standard messages") {
  CHECK(sha256_hex("") == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  CHECK(sha256_hex("abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  // 56 bytes: the padding spills into a second block.
  CHECK(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq") ==
        "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  CHECK(sha256_hex(std::string(1000000, 'a')) ==
        "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST_CASE("an empty file name is the seed's built-in reference model") {
  const CalibrationInUse c = load_calibration_in_use("");
  CHECK(c.model.kind() == gyrotc::fit::BiasModel::Kind::paper_reference);
  CHECK(describe(c) == "the seed's built-in reference model (paper_reference, -40..80 C)");
}

TEST_CASE("a calibration file is described by its path, model, range and the start of its SHA-256") {
  const std::string file = gyrotc::test::data_file("calibration_table2.toml");
  const CalibrationInUse c = load_calibration_in_use(file);
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(c.sha256 == sha256_hex(bytes));
  CHECK(describe(c) == file + ": " + std::string(c.model.kind_name()) + ", -40..80 C, sha256 " + c.sha256.substr(0, 16));
}

TEST_CASE("a calibration of the die is loaded with its lag and described as such") {
  const std::string file = gyrotc::test::scratch_dir() + "/die-calibration.toml";
  std::ofstream(file) << "format = \"gyrotc-calibration\"\nversion = 1\nkind = \"paper_reference\"\ndie_lag_s = 42.3\n";
  const CalibrationInUse c = load_calibration_in_use(file);
  CHECK(c.die_lag_s == 42.3);
  CHECK(describe(c) == file + ": paper_reference, -40..80 C of the die, 42.3 s behind the sensor, sha256 " +
                           c.sha256.substr(0, 16));
}

TEST_CASE("a missing calibration file is an error naming it, never the built-in model") {
  const std::string file = gyrotc::test::scratch_dir() + "/missing-calibration.toml";
  CHECK_THROWS_WITH(load_calibration_in_use(file), Catch::Contains(file + ": cannot open the calibration file"));
}

TEST_CASE("an invalid calibration file is an error naming the file and the line") {
  const std::string file = gyrotc::test::scratch_dir() + "/broken-calibration.toml";
  std::ofstream(file) << "format = \"gyrotc-calibration\"\nversion = 1\nkind = 7\n";
  CHECK_THROWS_WITH(load_calibration_in_use(file), Catch::Contains(file + ":3"));
}
