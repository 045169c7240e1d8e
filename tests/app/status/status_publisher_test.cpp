// The status publisher: the error held over the last minute, faults with
// their times, the files written, and the journal told of state changes only.
#include "gyrotc/app/daemon/status_publisher.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc::app;
namespace fs = std::filesystem;

namespace {

// What the code under test writes on stderr (the daemon's log).
class StderrCapture {
 public:
  StderrCapture() : path_(fs::path(gyrotc::test::scratch_dir()) / ("stderr_" + std::to_string(::getpid()))) {
    std::fflush(stderr);
    saved_ = ::dup(2);
    std::FILE* f = std::fopen(path_.c_str(), "w");
    ::dup2(::fileno(f), 2);
    std::fclose(f);
  }
  ~StderrCapture() { restore(); }
  std::string text() {
    restore();
    std::ifstream in(path_);
    return {std::istreambuf_iterator<char>(in), {}};
  }

 private:
  void restore() {
    if (saved_ < 0) return;
    std::fflush(stderr);
    ::dup2(saved_, 2);
    ::close(saved_);
    saved_ = -1;
  }
  fs::path path_;
  int saved_ = -1;
};

LoopStatus loop_at(double casing_c, double setpoint_c = 55.0, std::uint32_t flags = 0) {
  return LoopStatus{.casing_c = casing_c,
                    .ambient_c = 16.0,
                    .setpoint_c = setpoint_c,
                    .tec_a = 0.2,
                    .flags = flags,
                    .compensation_c = casing_c,
                    .estimate = {}};
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

StatusPublisherOptions in_memory() {
  StatusPublisherOptions o;
  o.status_file = "";
  o.identity.mode = "pid";
  return o;
}

}  // namespace

TEST_CASE("the error held is the largest over the last 60 s and forgets what is older") {
  StatusPublisher p(in_memory());
  p.update(loop_at(54.8), {}, {}, 0.0, 1000.0);
  for (int t = 1; t <= 60; ++t) p.update(loop_at(55.05), {}, {}, t, 1000.0 + t);
  CHECK(p.status().held_error_c == Approx(0.2));
  p.update(loop_at(55.05), {}, {}, 61.0, 1061.0);
  CHECK(p.status().held_error_c == Approx(0.05));
}

TEST_CASE("the error held counts from when the casing came into the band, not the warm-up before") {
  StatusPublisher p(in_memory());
  p.update(loop_at(40.0), {}, {}, 0.0, 1000.0);
  CHECK(std::isnan(p.status().held_error_c));
  p.update(loop_at(54.9), {}, {}, 1.0, 1001.0);
  CHECK(p.status().held_error_c == Approx(0.1));
}

TEST_CASE("a fault is kept with the time it was raised and the time it cleared") {
  StatusPublisher p(in_memory());
  p.update(loop_at(55.0), {}, {}, 0.0, 1000.0);
  p.update(loop_at(55.0, 55.0, kFlagTempStale | kFlagTecOff), {}, {}, 1.0, 1001.0);
  p.update(loop_at(55.0, 55.0, kFlagTempStale | kFlagTecOff), {}, {}, 2.0, 1002.0);
  p.update(loop_at(55.0), {}, {}, 3.0, 1003.0);
  REQUIRE(p.status().faults.size() == 1);  // tec_off is a state, not a fault
  CHECK(p.status().faults[0].name == "temp_stale");
  CHECK(p.status().faults[0].raised_unix_s == 1001.0);
  CHECK(p.status().faults[0].cleared_unix_s == 1003.0);
}

TEST_CASE("the journal hears a state once it has lasted three updates, not every flicker") {
  StderrCapture capture;
  {
    StatusPublisher p(in_memory());
    double t = 0.0;
    const auto at = [&](double casing_c) {
      p.update(loop_at(casing_c), {}, {}, t, 1000.0 + t);
      t += 1.0;
    };
    at(40.0);  // warming: told at once
    for (int i = 0; i < 10; ++i) {
      at(54.9);  // holding
      at(54.6);  // warming again: a flicker at the band's edge
    }
    for (int i = 0; i < 3; ++i) at(55.0);
  }
  const std::string log = capture.text();
  CHECK(count(log, "state: warming") == 1);
  CHECK(count(log, "state: holding") == 1);
}

TEST_CASE("the status file is written at each update and says how the daemon stopped") {
  StatusPublisherOptions o = in_memory();
  o.status_file = (fs::path(gyrotc::test::scratch_dir()) / ("pub_" + std::to_string(::getpid()) + ".json")).string();
  o.metrics_file = (fs::path(gyrotc::test::scratch_dir()) / ("pub_" + std::to_string(::getpid()) + ".prom")).string();
  StatusPublisher p(o);
  p.update(loop_at(55.01), {}, {}, 1.0, 1001.0);
  const auto read_json = [&] {
    std::ifstream in(o.status_file);
    return nlohmann::json::parse(in);
  };
  CHECK(read_json()["state"] == "holding");
  CHECK(fs::file_size(o.metrics_file) > 0);
  p.stopped("SIGTERM", {}, {}, 2.0, 1002.0);
  const nlohmann::json j = read_json();
  CHECK(j["running"] == false);
  CHECK(j["stopped_by"] == "SIGTERM");
  CHECK(j["tec_a"].get<double>() == 0.0);
  fs::remove(o.status_file);
  fs::remove(o.metrics_file);
}

TEST_CASE("a status file that cannot be written is a warning once, and the daemon goes on") {
  StderrCapture capture;
  {
    StatusPublisherOptions o = in_memory();
    o.status_file = "/nonexistent-dir/status.json";
    StatusPublisher p(o);
    for (int t = 0; t < 5; ++t) p.update(loop_at(55.0), {}, {}, t, 1000.0 + t);
  }
  const std::string log = capture.text();
  CHECK(count(log, "cannot write /nonexistent-dir/status.json") == 1);
}

TEST_CASE("a reload that moves the status file writes the new one at once and removes the old one") {
  const fs::path dir = gyrotc::test::scratch_dir();
  const std::string old_file = (dir / ("moved_from_" + std::to_string(::getpid()) + ".json")).string();
  const std::string new_file = (dir / ("moved_to_" + std::to_string(::getpid()) + ".json")).string();
  fs::remove(new_file);
  StatusPublisherOptions o = in_memory();
  o.status_file = old_file;
  StatusPublisher p(o);
  p.update(loop_at(55.0), {}, {}, 1.0, 1001.0);
  REQUIRE(fs::exists(old_file));
  p.set_files(new_file, "");
  // No update in between: `gyrotc status` must find the new file already.
  CHECK(fs::exists(new_file));
  CHECK_FALSE(fs::exists(old_file));
  fs::remove(new_file);
}
