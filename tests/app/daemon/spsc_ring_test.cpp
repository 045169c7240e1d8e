#include <cstdint>
#include <thread>

#include "gyrotc/app/runtime/spsc_ring.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::SpscRing;

TEST_CASE("ring buffer hands items over in order") {
  SpscRing<int, 8> ring;
  for (int i = 0; i < 5; ++i) REQUIRE(ring.try_push(i));
  int value = -1;
  for (int i = 0; i < 5; ++i) {
    REQUIRE(ring.try_pop(value));
    CHECK(value == i);
  }
  CHECK_FALSE(ring.try_pop(value));
}

TEST_CASE("a full ring buffer drops and counts instead of waiting") {
  SpscRing<int, 4> ring;
  for (int i = 0; i < 4; ++i) REQUIRE(ring.try_push(i));
  CHECK_FALSE(ring.try_push(99));
  CHECK_FALSE(ring.try_push(100));
  CHECK(ring.dropped() == 2);
  CHECK(ring.size() == 4);
  int value = -1;
  REQUIRE(ring.try_pop(value));
  CHECK(value == 0);  // the oldest items are kept, the newest dropped
  CHECK(ring.try_push(4));
  CHECK(ring.dropped() == 2);
}

TEST_CASE("ring buffer wraps around its capacity many times") {
  SpscRing<std::uint32_t, 4> ring;
  std::uint32_t value = 0;
  for (std::uint32_t i = 0; i < 1000; ++i) {
    REQUIRE(ring.try_push(i));
    REQUIRE(ring.try_pop(value));
    REQUIRE(value == i);
  }
  CHECK(ring.pushed() == 1000);
}

#if !defined(GYROTC_NO_GUEST_THREADS)  // hangs under qemu-user 7.2, see link.cmake
TEST_CASE("ring buffer between two threads loses nothing it accepted") {
  SpscRing<std::uint64_t, 64> ring;
  constexpr std::uint64_t kItems = 200000;
  std::uint64_t accepted_sum = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= kItems; ++i) {
      if (ring.try_push(i)) accepted_sum += i;
    }
  });
  std::uint64_t popped_sum = 0;
  std::uint64_t popped = 0;
  std::uint64_t last = 0;
  bool ordered = true;
  auto drain = [&] {
    std::uint64_t value = 0;
    while (ring.try_pop(value)) {
      ordered = ordered && value > last;
      last = value;
      popped_sum += value;
      ++popped;
    }
  };
  while (ring.pushed() + ring.dropped() < kItems) drain();
  producer.join();
  drain();
  CHECK(ordered);
  CHECK(popped + ring.dropped() == kItems);
  CHECK(popped_sum == accepted_sum);
}
#endif
