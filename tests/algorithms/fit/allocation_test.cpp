// Counts heap allocations so the per-sample paths can be shown allocation-free.
#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "gyrotc/algorithms/fit/bp_network_fit.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/fit/spline_fit.hpp"
#include "gyrotc_catch.hpp"
#include "table2.hpp"

namespace {
std::atomic<long> g_allocations{0};
double* volatile g_sink = nullptr;
}

// Every non-aligned form is replaced so that allocation and release always pair up.
namespace {
void* counted_malloc(std::size_t size) noexcept {
  ++g_allocations;
  return std::malloc(size ? size : 1);
}
}  // namespace

void* operator new(std::size_t size) {
  if (void* p = counted_malloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = counted_malloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return counted_malloc(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return counted_malloc(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }

using namespace gyrotc::fit;

TEST_CASE("compensation does not allocate for any model kind") {
  {
    const long before = g_allocations.load();
    std::vector<double> probe(3);  // the counter must see an ordinary allocation
    g_sink = probe.data();  // escapes, so an optimiser cannot elide the allocation
    CHECK(g_allocations.load() > before);
  }
  const auto table = gyrotc::test::read_table2();
  BpTrainOptions o;
  o.hidden = {10, 10, 10};
  o.restarts = 1;
  o.max_epochs = 2;
  const Compensator models[] = {
      Compensator{BiasModel::paper_reference()},
      Compensator{BiasModel::polynomial({20.0, 60.0, {80.0, -30.0, 5.0, 1.0}, -40.0, 80.0})},
      Compensator{BiasModel::bp_network(train_bp_network(table.temp_c, table.gyro_mv, o).net)},
      Compensator{BiasModel::spline(fit_interpolating_spline(table.temp_c, table.gyro_mv))},
  };
  for (const Compensator& c : models) {
    const long before = g_allocations.load();
    double sum = 0.0;
    for (double t = -50.0; t <= 90.0; t += 0.5) sum += c.compensate(90.0, t).rate_dps;
    CHECK(g_allocations.load() == before);
    CHECK(std::isfinite(sum));
  }
}
