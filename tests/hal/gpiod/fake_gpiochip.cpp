#include "fake_gpiochip.hpp"

#include <ctime>

FakeGpiochip::FakeGpiochip() {
  lines.resize(32);
  lines[25].name = "DRDY";
  lines[24].name = "OPA548_ES";
  lines[23].name = "OPA548_ES_SENSE";
}

FakeGpiochip*& FakeGpiochip::armed() {
  static FakeGpiochip* fake = nullptr;
  return fake;
}

bool FakeGpiochip::matches(const std::string& description) const {
  return description == name || description == path() || description == label ||
         "gpiochip" + description == name;
}

void FakeGpiochip::drive(unsigned offset, int level_now, std::uint64_t time_ns) {
  FakeLine& l = lines.at(offset);
  const int before = l.logical();
  l.level = level_now;
  const int after = l.logical();
  if (!l.requested || before == after) return;
  const bool rising = after > before;
  const bool wanted = l.edges == FakeEdges::both || (rising && l.edges == FakeEdges::rising) ||
                      (!rising && l.edges == FakeEdges::falling);
  if (wanted) l.events.push_back({rising, time_ns});
}

std::uint64_t monotonic_now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}
