#include "gyrotc/app/runtime/latency_histogram.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::app::LatencyHistogram;

TEST_CASE("latency histogram of nothing is all zero") {
  const LatencyHistogram h;
  const auto s = h.summary();
  CHECK(s.count == 0);
  CHECK(s.max_s == 0.0);
}

TEST_CASE("latency histogram gives exact min, mean and max and the 99th percentile bin") {
  LatencyHistogram h;
  // 990 wake-ups at 20 us and 10 at 500 us: the 99th percentile is 20 us.
  for (int i = 0; i < 990; ++i) h.add(20e-6);
  for (int i = 0; i < 10; ++i) h.add(500e-6);
  auto s = h.summary();
  CHECK(s.count == 1000);
  CHECK(s.min_s == Approx(20e-6));
  CHECK(s.max_s == Approx(500e-6));
  CHECK(s.avg_s == Approx((990 * 20e-6 + 10 * 500e-6) / 1000));
  CHECK(s.p99_s == Approx(21e-6));  // upper edge of the 1 us bin holding 20 us
  CHECK_FALSE(s.p99_over);
  // One more slow wake-up pushes the 99th percentile into the 500 us bin.
  for (int i = 0; i < 2; ++i) h.add(500e-6);
  s = h.summary();
  CHECK(s.p99_s == Approx(501e-6));
}

TEST_CASE("latency histogram uses 10 us bins above 1 ms and flags overflow") {
  LatencyHistogram h;
  for (int i = 0; i < 100; ++i) h.add(2.345e-3);
  CHECK(h.summary().p99_s == Approx(2.35e-3));
  LatencyHistogram slow;
  for (int i = 0; i < 100; ++i) slow.add(0.5);
  const auto s = slow.summary();
  CHECK(s.p99_over);
  CHECK(s.max_s == Approx(0.5));
}

TEST_CASE("latency histogram counts negative latencies as zero") {
  LatencyHistogram h;
  h.add(-1e-6);
  CHECK(h.summary().min_s == 0.0);
  CHECK(h.summary().count == 1);
}
