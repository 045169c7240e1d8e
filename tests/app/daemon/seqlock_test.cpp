#include <atomic>
#include <cstdint>
#include <thread>

#include "gyrotc/app/daemon/seqlock.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::Seqlock;

namespace {

// Three fields the writer keeps consistent with each other: a torn copy
// shows up as a mismatch.
struct Reading {
  double temp_c;
  double time_s;
  std::uint64_t check;
  bool valid;
};

Reading make_reading(std::uint64_t n) {
  return {static_cast<double>(n) * 0.0625, static_cast<double>(n) * 0.75, n * 3U + 1U, n % 2U == 0U};
}

[[maybe_unused]] bool consistent(const Reading& r) {  // unused when the threaded test is compiled out
  const auto n = static_cast<std::uint64_t>(r.temp_c / 0.0625);
  return r.time_s == static_cast<double>(n) * 0.75 && r.check == n * 3U + 1U && r.valid == (n % 2U == 0U);
}

}  // namespace

TEST_CASE("seqlock starts at the default value, version 0") {
  Seqlock<Reading> lock;
  Reading r{1, 1, 1, true};
  std::uint64_t version = 99;
  REQUIRE(lock.try_load(r, &version));
  CHECK(version == 0);
  CHECK(r.temp_c == 0.0);
  CHECK_FALSE(r.valid);
}

TEST_CASE("seqlock returns the last stored value and counts stores") {
  Seqlock<Reading> lock;
  lock.store(make_reading(4));
  lock.store(make_reading(7));
  std::uint64_t version = 0;
  const Reading r = lock.load(&version);
  CHECK(version == 2);
  CHECK(r.check == make_reading(7).check);
  CHECK(lock.version() == 2);
}

#if !defined(GYROTC_NO_GUEST_THREADS)  // hung under qemu-user 7.2 (cross-build ctest run), see link.cmake
TEST_CASE("seqlock readers never see a torn value while the writer runs") {
  Seqlock<Reading> lock;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t n = 1; n <= 300000; ++n) lock.store(make_reading(n));
    done = true;
  });
  std::uint64_t reads = 0;
  std::uint64_t failed_attempts = 0;
  bool all_consistent = true;
  std::uint64_t last_version = 0;
  bool versions_monotonic = true;
  while (!done) {
    Reading r{};
    std::uint64_t version = 0;
    if (!lock.try_load(r, &version)) {
      ++failed_attempts;
      continue;
    }
    if (version == 0) continue;  // the initial T{}, before the first store
    ++reads;
    all_consistent = all_consistent && consistent(r);
    versions_monotonic = versions_monotonic && version >= last_version;
    last_version = version;
  }
  writer.join();
  CHECK(reads > 0);
  CHECK(all_consistent);
  CHECK(versions_monotonic);
  INFO("attempts that overlapped a write: " << failed_attempts);
  CHECK(lock.load().check == make_reading(300000).check);
}
#endif
