#include "gyrotc/hal/sim/sim_ads1251.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "gyrotc/hal/chips/ads1251.hpp"

namespace gyrotc::hal {

namespace {

// ADS1251/ADS1253 datasheet, digital timing, in fCLK periods from the DRDY
// falling edge: t2 (LOW) 6, t3 (HIGH) 6, DOUT mode 348, t4 (HIGH) 24.
constexpr double kPulseLowClocks = 6.0;
constexpr double kDoutStartClocks = 12.0;
constexpr double kDoutEndClocks = 12.0 + 348.0;
constexpr int kFrameBits = 24;

std::uint64_t splitmix64(std::uint64_t& state) noexcept {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace

SimAds1251::SimAds1251(Input& input, Clock& clock, const Config& config) noexcept
    : input_(input),
      clock_(clock),
      config_(config),
      tclk_s_(1.0 / config.fclk_hz),
      period_s_(Ads1251::kClocksPerSample / config.fclk_hz),
      codes_per_mv_(8388608.0 / (config.vref_v * 1000.0)),
      rng_(config.timing.seed) {
  // Idle HIGH (t4) until the first DRDY edge after now.
  t_s_ = clock.now_s();
  last_visible_s_ = t_s_;
  cycle_ = static_cast<std::int64_t>(std::floor(t_s_ / period_s_));
  edge_s_ = static_cast<double>(cycle_) * period_s_;
  enter(Segment::drdy_high);
  history_index_.fill(-1);
}

SimAds1251::Counters SimAds1251::counters() const noexcept {
  return {.conversions = conversions_.load(std::memory_order_relaxed),
          .reads = reads_.load(std::memory_order_relaxed),
          .clean_reads = clean_reads_.load(std::memory_order_relaxed),
          .corrupted_reads = corrupted_reads_.load(std::memory_order_relaxed),
          .dropped_events = dropped_events_.load(std::memory_order_relaxed),
          .late_edges = late_edges_.load(std::memory_order_relaxed)};
}

double SimAds1251::uniform(double lo, double hi) noexcept {
  if (!(hi > lo)) return lo;  // no draw: a zero range keeps runs without randomness identical
  return lo + (hi - lo) * static_cast<double>(splitmix64(rng_) >> 11) * 0x1.0p-53;
}

double SimAds1251::wake_latency_s() noexcept {
  const Timing& t = config_.timing;
  if (t.stall_probability > 0.0 && uniform(0.0, 1.0) < t.stall_probability) {
    return uniform(t.wake_max_s, t.stall_max_s);
  }
  return uniform(t.wake_min_s, t.wake_max_s);
}

// --- the pin -------------------------------------------------------------------

void SimAds1251::enter(Segment segment) noexcept {
  segment_ = segment;
  switch (segment) {
    case Segment::pulse_low: boundary_s_ = edge_s_ + kPulseLowClocks * tclk_s_; return;
    case Segment::pulse_high: boundary_s_ = edge_s_ + kDoutStartClocks * tclk_s_; return;
    case Segment::dout: boundary_s_ = edge_s_ + kDoutEndClocks * tclk_s_; return;
    case Segment::drdy_high:
      boundary_s_ = static_cast<double>(cycle_ + 1) * period_s_;
      // After a late (anchored) edge the conversions keep their period from
      // it: the emulated clock's phase slips, as no conversion is dropped.
      if (config_.pin_listener != nullptr) boundary_s_ = std::max(boundary_s_, edge_s_ + period_s_);
      return;
  }
}

bool SimAds1251::dout_bit() const noexcept {
  return pointer_ < kFrameBits && ((frame_ >> (kFrameBits - 1 - pointer_)) & 1u) != 0;
}

void SimAds1251::cross_boundary(double t) noexcept {
  switch (segment_) {
    case Segment::pulse_low:
      enter(Segment::pulse_high);
      set_level(true, t);
      break;
    case Segment::pulse_high:
      enter(Segment::dout);
      set_level(dout_bit(), t);
      break;
    case Segment::dout:
      enter(Segment::drdy_high);
      set_level(true, t);
      break;
    case Segment::drdy_high: {
      // The DRDY edge: conversion k is in the output register, the shift
      // pointer is back at its MSB.
      ++cycle_;
      if (t - boundary_s_ > kPulseLowClocks * tclk_s_) bump(late_edges_);  // written later than its pulse lasts
      edge_s_ = t;
      const std::int32_t code = code_for_mv(input_.input_mv(t));
      frame_ = static_cast<std::uint32_t>(code) & 0xFFFFFFu;
      pointer_ = 0;
      const auto slot = static_cast<std::size_t>(cycle_) % kHistory;
      history_index_[slot] = cycle_;
      history_code_[slot] = code;
      bump(conversions_);
      enter(Segment::pulse_low);
      set_level(false, t);
      break;
    }
  }
  t_s_ = t;
}

void SimAds1251::advance_to(double t_s) noexcept {
  if (!(t_s > t_s_)) return;
  for (;;) {
    const double boundary_s = boundary_s_;
    if (glitch_s_ <= t_s && glitch_s_ <= boundary_s) {
      // A spike too short to change the level the state machine sees.
      if (config_.pin_listener != nullptr) {
        config_.pin_listener->on_pin_level(false, glitch_s_);
        config_.pin_listener->on_pin_level(level_, glitch_s_);
      } else {
        label_visible(glitch_s_);
        queue_edge(glitch_s_, true, uniform(0.0, config_.timing.irq_delay_max_s));
      }
      glitch_s_ = std::numeric_limits<double>::infinity();
    } else if (boundary_s <= t_s) {
      // An emulated pin moves when its thread runs, possibly late: the
      // conversion's edge is when the pin really falls.
      const bool anchored = config_.pin_listener != nullptr && segment_ == Segment::drdy_high;
      cross_boundary(anchored ? t_s : boundary_s);
    } else {
      break;
    }
  }
  t_s_ = t_s;
  label_visible(t_s);
}

void SimAds1251::label_visible(double t_s) noexcept {
  if (config_.request != EdgeRequest::both_v1) return;
  for (std::size_t i = 0; i < count_; ++i) {
    Event& e = queue_[(head_ + i) % kQueueEvents];
    if (e.visible_s > t_s) break;
    if (!e.labelled) {
      // The v1 IRQ thread reads the line to tell a rising from a falling edge.
      e.falling = !level_;
      e.labelled = true;
    }
  }
}

void SimAds1251::set_level(bool level, double t_s) noexcept {
  if (stall_.load(std::memory_order_relaxed)) level = true;  // a stalled DRDY never falls
  if (level == level_) return;
  if (config_.pin_listener != nullptr) {  // the kernel queues the edges of a real line
    level_ = level;
    config_.pin_listener->on_pin_level(level, t_s);
    return;
  }
  if (config_.request == EdgeRequest::both_v1) label_visible(t_s);  // readable before this edge: the old level
  level_ = level;
  queue_edge(t_s, !level, uniform(0.0, config_.timing.irq_delay_max_s));
}

void SimAds1251::queue_edge(double t_s, bool falling, double irq_delay_s) noexcept {
  if (config_.request == EdgeRequest::falling && !falling) return;  // rising edges are not requested
  Event e;
  const Timing& timing = config_.timing;
  const bool held_off = timing.late_stamp_probability > 0.0 && uniform(0.0, 1.0) < timing.late_stamp_probability;
  e.stamp_s = t_s + (held_off ? uniform(timing.stamp_delay_max_s, timing.late_stamp_max_s)
                              : uniform(0.0, timing.stamp_delay_max_s));
  e.visible_s = std::max({t_s + irq_delay_s, e.stamp_s, last_visible_s_});
  last_visible_s_ = e.visible_s;
  e.falling = falling;
  e.labelled = config_.request == EdgeRequest::falling;
  if (count_ == kQueueEvents) {
    bump(dropped_events_);
    return;
  }
  queue_[(head_ + count_) % kQueueEvents] = e;
  ++count_;
}

void SimAds1251::shift(double t_s) noexcept {
  if (pointer_ <= kFrameBits) ++pointer_;  // past the 24th bit the pin stays LOW
  if (segment_ == Segment::dout) set_level(dout_bit(), t_s);
}

double SimAds1251::run_pin() noexcept {
  advance_to(clock_.now_s());
  return boundary_s_;
}

// --- the DRDY line -------------------------------------------------------------

Status SimAds1251::Drdy::do_set(bool) noexcept {
  return Error::make(ErrorCode::invalid_config, "sim:ads1251-drdy is an input");
}

Result<bool> SimAds1251::Drdy::do_get() noexcept {
  chip_.advance_to(chip_.clock_.now_s());
  return chip_.level_;
}

Result<double> SimAds1251::Drdy::do_wait_edge(Edge edge, double timeout_s) noexcept {
  return chip_.wait(edge, timeout_s);
}

Result<int> SimAds1251::Drdy::do_discard_edges() noexcept {
  SimAds1251& c = chip_;
  c.advance_to(c.clock_.now_s());
  int dropped = 0;
  while (c.count_ > 0 && c.queue_[c.head_].visible_s <= c.t_s_) {
    c.head_ = (c.head_ + 1) % kQueueEvents;
    --c.count_;
    ++dropped;
  }
  return dropped;
}

Result<double> SimAds1251::wait(Edge edge, double timeout_s) noexcept {
  const double deadline_s = clock_.now_s() + std::max(timeout_s, 0.0);
  advance_to(clock_.now_s());
  bool slept = false;
  for (;;) {
    while (count_ > 0 && queue_[head_].visible_s <= t_s_) {
      const Event e = queue_[head_];
      head_ = (head_ + 1) % kQueueEvents;
      --count_;
      if (e.falling != (edge == Edge::falling)) continue;  // not the edge asked for: skipped
      // An event queued before the call is read at once; one the reader
      // slept for wakes it up late.
      if (slept) clock_.sleep_until(e.visible_s + wake_latency_s());
      return e.stamp_s;
    }
    // Nothing readable yet: move the pin on to the next moment something can
    // become readable (the reader sleeps meanwhile; the clock follows below).
    const double next_s = count_ > 0 ? queue_[head_].visible_s : boundary_s_;
    if (next_s > deadline_s) {
      advance_to(deadline_s);
      clock_.sleep_until(deadline_s);
      return Error::make(ErrorCode::timeout, "sim:ads1251: no DRDY %s edge within %.3f s",
                         edge == Edge::falling ? "falling" : "rising", timeout_s);
    }
    advance_to(next_s);
    slept = true;
  }
}

// --- the SPI bus ---------------------------------------------------------------

Status SimAds1251::Bus::do_configure(const SpiConfig& config) noexcept {
  // Any mode is accepted, as by the part: a wrong one shows in the data.
  // Words other than 8 bits are the controller's business (spidev packs
  // them into bytes on the wire).
  if (config.mode > 3 || config.bits_per_word != 8 || config.speed_hz == 0) {
    return Error::make(ErrorCode::invalid_config,
                       "sim:ads1251: SPI mode %u, %u bits per word, %u Hz: the bus needs mode 0..3, 8-bit "
                       "bytes on the wire and a clock",
                       config.mode, config.bits_per_word, config.speed_hz);
  }
  chip_.spi_mode_ = config.mode;
  chip_.bit_s_ = 1.0 / config.speed_hz;
  return {};
}

Status SimAds1251::Bus::do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
  return chip_.transfer(tx, rx);
}

Status SimAds1251::transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
  if (spi_error_.load(std::memory_order_relaxed)) {
    return Error::make(ErrorCode::io, "sim:ads1251: SPI transfer failed (injected fault)");
  }
  if (spi_mode_ > 3) return Error::make(ErrorCode::invalid_config, "sim:ads1251: SPI not configured");
  if (tx.size() != rx.size()) return Error::make(ErrorCode::invalid_config, "sim:ads1251: tx/rx sizes differ");
  const double start_s = clock_.now_s() + uniform(0.0, config_.timing.spi_start_max_s);
  advance_to(start_s);
  const std::int64_t cycle = cycle_;
  last_transfer_.start_s = start_s;
  last_transfer_.edge_s = edge_s_;
  // Clean: in mode 0, from the MSB of one conversion, every bit sampled inside its DOUT mode.
  const bool sample_after_shift = spi_mode_ != 0;
  bool clean = !sample_after_shift && rx.size() * 8 == kFrameBits && segment_ == Segment::dout && pointer_ == 0;
  const double end_s = start_s + static_cast<double>(rx.size() * 8) * bit_s_;  // the last falling SCLK edge
  // Mode 0: each bit is sampled on the rising SCLK edge, shifted on the falling one.
  const int bits = static_cast<int>(rx.size()) * 8;
  if (bits < 64 && boundary_s_ > end_s && glitch_s_ > end_s && config_.request == EdgeRequest::falling &&
      !stall_.load(std::memory_order_relaxed) && !sample_after_shift && config_.pin_listener == nullptr) {
    // The usual read: the pin's segment holds for the whole transfer, so
    // only the shifts move it (in DOUT mode), and the IRQ thread that queues
    // the burst of data edges wakes once for it. The levels the pin shows,
    // MSB first from bit 63: L0 now, Lj after the j-th shift.
    std::uint64_t levels = 0;
    if (segment_ != Segment::dout) {
      levels = level_ ? ~std::uint64_t{0} : 0;
    } else if (pointer_ < kFrameBits) {
      levels = static_cast<std::uint64_t>(frame_) << (64 - kFrameBits + pointer_);
    }
    const std::uint64_t sampled = levels >> (64 - bits);
    for (std::size_t i = 0; i < rx.size(); ++i) {
      rx[i] = static_cast<std::uint8_t>(sampled >> (8 * (rx.size() - 1 - i)));
    }
    // A falling edge at shift j: L(j-1) = 1, Lj = 0.
    std::uint64_t falling = levels & ~(levels << 1) & ~(~std::uint64_t{0} >> bits);
    const double irq_delay_s = uniform(0.0, config_.timing.irq_delay_max_s);
    while (falling != 0) {
      const int j = std::countl_zero(falling) + 1;
      queue_edge(start_s + j * bit_s_, true, irq_delay_s);
      falling &= ~(std::uint64_t{1} << (64 - j));
    }
    level_ = ((levels >> (63 - bits)) & 1u) != 0;
    pointer_ = std::min(pointer_ + bits, kFrameBits + 1);
    t_s_ = end_s;
  } else {
    std::size_t bit = 0;
    for (std::uint8_t& byte : rx) {
      byte = 0;
      for (int b = 0; b < 8; ++b, ++bit) {
        const double falling_s = start_s + static_cast<double>(bit + 1) * bit_s_;
        if (sample_after_shift) {
          advance_to(falling_s);
          shift(falling_s);
          byte = static_cast<std::uint8_t>(byte << 1 | (level_ ? 1 : 0));
          continue;
        }
        advance_to(start_s + (static_cast<double>(bit) + 0.5) * bit_s_);
        clean = clean && segment_ == Segment::dout && cycle_ == cycle;
        byte = static_cast<std::uint8_t>(byte << 1 | (level_ ? 1 : 0));
        advance_to(falling_s);
        shift(falling_s);
      }
    }
  }
  bump(reads_);
  bump(clean ? clean_reads_ : corrupted_reads_);
  last_transfer_.clean = clean;
  clock_.sleep_until(end_s + uniform(0.0, config_.timing.spi_return_max_s));
  return {};
}

}  // namespace gyrotc::hal
