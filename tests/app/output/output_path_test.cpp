// Output paths are made ready before the work: a missing last folder is created,
// places that cannot be written are refused at once, naming the option.
#include "gyrotc/app/support/output_path.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "run_command.hpp"
#include "input_error_of.hpp"

using namespace gyrotc::app;
namespace fs = std::filesystem;

namespace {

// A fresh scratch folder for one test.
struct Scratch {
  fs::path dir;
  explicit Scratch(const std::string& name) : dir(fs::path(gyrotc::test::scratch_dir()) / ("output_" + name)) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Scratch() { fs::remove_all(dir); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
};

std::string failure_of(void (*prepare)(const std::string&, const std::string&), const std::string& path,
                       const std::string& option) {
  try {
    prepare(path, option);
  } catch (const RuntimeFailure& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("a file's missing folder is created when its own parent exists") {
  Scratch s("parent");
  const fs::path file = s.dir / "a" / "plot.svg";
  prepare_output_file(file.string(), "--plot");
  CHECK(fs::is_directory(file.parent_path()));
  CHECK_FALSE(fs::exists(file));  // nothing is written before the work
}

TEST_CASE("a chain of missing folders is refused, naming the first one missing, and nothing is created") {
  Scratch s("chain");
  const std::string path = (s.dir / "a" / "b" / "plot.svg").string();
  CHECK(failure_of(prepare_output_file, path, "--plot") ==
        "--plot " + path + ": the folder '" + (s.dir / "a").string() +
            "' does not exist (only the last folder of an output path is created)");
  CHECK_FALSE(fs::exists(s.dir / "a"));
}

TEST_CASE("a file in the current folder needs no folder") {
  CHECK_NOTHROW(prepare_output_file("gyrotc_output_plain.csv", "--out"));
}

TEST_CASE("a file whose parent is a file is refused, naming the option and the path") {
  Scratch s("parent_file");
  std::ofstream(s.dir / "f") << "x";
  const std::string path = (s.dir / "f" / "x.svg").string();
  const std::string why = failure_of(prepare_output_file, path, "--plot");
  CHECK(why == "--plot " + path + ": '" + (s.dir / "f").string() + "' is not a folder");
}

TEST_CASE("a file name that is a folder is refused") {
  Scratch s("is_dir");
  CHECK(failure_of(prepare_output_file, s.dir.string(), "--out") == "--out " + s.dir.string() + ": is a folder, not a file");
}

TEST_CASE("a missing output folder is created") {
  Scratch s("dir");
  const fs::path dir = s.dir / "x";
  prepare_output_dir(dir.string(), "--report");
  CHECK(fs::is_directory(dir));
}

TEST_CASE("a missing output folder written with a trailing slash is created, like the same name without") {
  Scratch s("dir_slash");
  const fs::path dir = s.dir / "x";
  prepare_output_dir(dir.string() + "/", "--out");
  CHECK(fs::is_directory(dir));
}

TEST_CASE("an output folder that exists as a file is refused") {
  Scratch s("dir_file");
  std::ofstream(s.dir / "f") << "x";
  const std::string path = (s.dir / "f").string();
  CHECK(failure_of(prepare_output_dir, path, "--out") == "--out " + path + ": exists and is not a folder");
}

TEST_CASE("a folder the system will not create is refused before any work") {
  CHECK(failure_of(prepare_output_dir, "/proc/gyrotc-no", "--out").find("--out /proc/gyrotc-no: cannot create") == 0);
}

TEST_CASE("simulate writes its time series, summary and plot into a folder that did not exist") {
  Scratch s("simulate");
  const fs::path out = s.dir / "run";
  gyrotc::test::run_command(add_simulate_command, "simulate",
                            {"--profile", "table2", "--controller", "off", "--sample-rate-hz", "5", "--out",
                             out.string(), "--plot", (out / "run.svg").string()});
  CHECK(fs::exists(out / "simulation.csv"));
  CHECK(fs::exists(out / "summary.json"));
  CHECK(fs::exists(out / "run.svg"));
}

TEST_CASE("simulate --compare overlays another run's folder, and refuses a folder without a run before running") {
  Scratch s("compare");
  const fs::path first = s.dir / "first";
  const std::vector<std::string> quick = {"--profile", "table2", "--controller", "off", "--sample-rate-hz", "5"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = quick;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  gyrotc::test::run_command(add_simulate_command, "simulate", with({"--out", first.string()}));
  gyrotc::test::run_command(add_simulate_command, "simulate",
                            with({"--plot", (s.dir / "both.svg").string(), "--compare", first.string()}));
  std::ifstream svg(s.dir / "both.svg");
  const std::string text((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
  CHECK(text.find("TEC, vs first") != std::string::npos);
  const std::string why = gyrotc::test::input_error_of([&] {
    gyrotc::test::run_command(add_simulate_command, "simulate",
                              with({"--plot", (s.dir / "x.svg").string(), "--compare", s.dir.string()}));
  });
  CHECK(why == "--compare " + s.dir.string() + ": no simulation.csv there (the --out folder of another simulate run)");
  CHECK_FALSE(fs::exists(s.dir / "x.svg"));
}
