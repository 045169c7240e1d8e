// The gyrotc command line as a user meets it: what a mistake prints and the
// exit status it gives (run_cli, the end of main(), on the real commands).
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc_catch.hpp"

namespace {

struct CliRun {
  int status = -1;
  std::string out;
  std::string err;
};

CliRun run_gyrotc(std::vector<std::string> args) {
  args.insert(args.begin(), "gyrotc");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  CLI::App cli;
  gyrotc::app::add_gyrotc_commands(cli);
  std::ostringstream out;
  std::ostringstream err;
  CliRun run;
  run.status = gyrotc::app::run_cli(cli, static_cast<int>(argv.size()), argv.data(), "gyrotc", out, err);
  run.out = out.str();
  run.err = err.str();
  return run;
}

std::size_t lines(const std::string& text) {
  std::size_t n = 0;
  for (const char c : text) n += c == '\n' ? 1 : 0;
  return n;
}

}  // namespace

TEST_CASE("bare gyrotc prints a short help with one line per command and exits 0", "[cli]") {
  const CliRun run = run_gyrotc({});
  CHECK(run.status == 0);
  CHECK(run.err.empty());
  CHECK(run.out.rfind("gyrotc: temperature compensation and control of a MEMS gyroscope\n", 0) == 0);
  for (const char* command : {"simulate", "fit", "identify", "tune", "allan", "probe", "run", "record", "safe-off"}) {
    INFO(command);
    CHECK(run.out.find("\n  " + std::string(command) + " ") != std::string::npos);
  }
  CHECK(lines(run.out) <= 20);
}

TEST_CASE("a misspelt command is an exit-2 usage error with the command it probably meant", "[cli]") {
  const CliRun run = run_gyrotc({"smulate", "--profile", "table2"});
  CHECK(run.status == 2);
  CHECK(run.err.rfind("gyrotc: error: unknown command 'smulate'; did you mean 'simulate'?\n", 0) == 0);
  CHECK(run.out.empty());
}

TEST_CASE("a word nothing like a command gets no suggestion, only where the commands are listed", "[cli]") {
  const CliRun run = run_gyrotc({"xyzzy"});
  CHECK(run.status == 2);
  CHECK(run.err == "gyrotc: error: unknown command 'xyzzy'\nRun 'gyrotc --help' for the commands.\n");
}

TEST_CASE("a misspelt option names its command and the option it probably meant", "[cli]") {
  const CliRun run = run_gyrotc({"simulate", "--profle", "table2"});
  CHECK(run.status == 2);
  CHECK(run.err.rfind("gyrotc: error: unknown option '--profle' for 'simulate'; did you mean '--profile'?\n", 0) ==
        0);
  CHECK(run.err.find("Run 'gyrotc simulate --help'") != std::string::npos);
}

TEST_CASE("a negative duration is refused in one short line, not a 309-digit range", "[cli]") {
  const CliRun run = run_gyrotc({"run", "--duration", "-5"});
  CHECK(run.status == 2);
  REQUIRE(run.err.rfind("gyrotc: error: ", 0) == 0);
  const std::string first = run.err.substr(0, run.err.find('\n'));
  CHECK(first.find("--duration") != std::string::npos);
  CHECK(first.find("-5") != std::string::npos);
  CHECK(first.size() < 100);
}

TEST_CASE("a negative count is refused, not wrapped to 2^64 - 1", "[cli]") {
  const CliRun run = run_gyrotc({"fit", "--data", "no-such-file.csv", "--seed", "-1"});
  CHECK(run.status == 2);
  CHECK(run.err.find("--seed") != std::string::npos);
  CHECK(run.err.find("18446744073709551615") == std::string::npos);
  CHECK(run.err.find("no-such-file.csv") == std::string::npos);  // refused before the command ran
}

TEST_CASE("a value that is not a number is a usage error naming the option", "[cli]") {
  const CliRun run = run_gyrotc({"run", "--duration", "ten"});
  CHECK(run.status == 2);
  CHECK(run.err.rfind("gyrotc: error: ", 0) == 0);
  CHECK(run.err.find("--duration") != std::string::npos);
}

TEST_CASE("a stray argument is a usage error with the common prefix", "[cli]") {
  const CliRun run = run_gyrotc({"simulate", "--profile", "table2", "extra"});
  CHECK(run.status == 2);
  CHECK(run.err.rfind("gyrotc: error: ", 0) == 0);
  CHECK(run.err.find("extra") != std::string::npos);
}

TEST_CASE("a missing required option is a usage error with the common prefix", "[cli]") {
  const CliRun run = run_gyrotc({"tune", "--out", "controller.toml"});
  CHECK(run.status == 2);
  CHECK(run.err.rfind("gyrotc: error: ", 0) == 0);
  CHECK(run.err.find("--data") != std::string::npos);
}

TEST_CASE("a missing input file is the same kind of error for every command", "[cli]") {
  for (const char* command : {"fit", "identify", "allan"}) {
    INFO(command);
    const CliRun run = run_gyrotc({command, "--data", "no-such-file.csv"});
    CHECK(run.status == 2);
    CHECK(run.err.rfind("gyrotc: error: ", 0) == 0);
    CHECK(run.err.find("no-such-file.csv") != std::string::npos);
  }
}

TEST_CASE("a folder given as the data file is named as a folder, with the record inside it", "[cli]") {
  const std::filesystem::path folder = std::filesystem::temp_directory_path() / "gyrotc-cli-run-folder";
  std::filesystem::create_directories(folder);
  std::ofstream(folder / "record.csv") << "time_s,casing_c\n";
  const std::string out = (folder / "out.toml").string();
  for (const char* command : {"tune", "fit"}) {
    INFO(command);
    const CliRun run = run_gyrotc({command, "--data", folder.string(), "--out", out});
    CHECK(run.status == 2);
    CHECK(run.err.rfind("gyrotc: error: " + folder.string() + ": is a folder, not a CSV file", 0) == 0);
    CHECK(run.err.find((folder / "record.csv").string() + "?") != std::string::npos);
  }
  std::filesystem::remove_all(folder);
}

TEST_CASE("--help and --version still exit 0 on stdout", "[cli]") {
  const CliRun help = run_gyrotc({"simulate", "--help"});
  CHECK(help.status == 0);
  CHECK(help.out.find("--profile") != std::string::npos);
  const CliRun version = run_gyrotc({"--version"});
  CHECK(version.status == 0);
  CHECK(version.out.rfind("gyrotc ", 0) == 0);
}

TEST_CASE("an output folder that cannot be made is refused before the run", "[cli]") {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "gyrotc-cli-not-a-folder";
  std::ofstream(file) << "a file where the run's folder should be\n";
  const CliRun run = run_gyrotc({"simulate", "--profile", "table2", "--out", file.string()});
  std::filesystem::remove(file);
  CHECK(run.status != 0);
  CHECK(run.err.rfind("gyrotc: error: ", 0) == 0);
  CHECK(run.err.find("--out") != std::string::npos);
  CHECK(run.out.empty());  // nothing simulated
}

TEST_CASE("record without --pid or --experiment is a usage error naming the choice, before the board is touched",
          "[cli]") {
  const CliRun run = run_gyrotc({"record", "--config", "no-such-config.toml", "--out", "never-written.csv"});
  CHECK(run.status == 2);
  CHECK(run.err.rfind("gyrotc: error: record: say what drives the TEC: --pid off", 0) == 0);
  CHECK(run.err.find("--experiment tune") != std::string::npos);
  CHECK(run.err.find("no-such-config.toml") == std::string::npos);  // refused before the config was read
  CHECK_FALSE(std::filesystem::exists("never-written.csv"));
}

TEST_CASE("record with both --pid and --experiment is a usage error: the experiment drives the TEC", "[cli]") {
  const CliRun run = run_gyrotc(
      {"record", "--config", "no-such-config.toml", "--out", "never-written.csv", "--pid", "on", "--experiment", "tune"});
  CHECK(run.status == 2);
  CHECK(run.err.find("choose one") != std::string::npos);
}

// In process, not a gyrotc child: under qemu-user a child needs the host's
// binfmt_misc registration for aarch64, which a container may not have.
TEST_CASE("calibrate without --config or --data is a usage error naming both", "[cli]") {
  const CliRun run = run_gyrotc({"calibrate", "--out", "unused.toml"});
  CHECK(run.status == 2);
  CHECK(run.err.find("give --config FILE (run the sweep on the board) or --data RECORD") != std::string::npos);
}
