#pragma once

#include <array>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace gyrotc::app {

// A fixed-size single-producer single-consumer queue: the real-time thread
// pushes, one non-real-time thread pops. Neither side blocks, locks or
// allocates; when the consumer falls behind (a stalled pipe, a full disk) the
// producer's push fails and the item is dropped and counted, so the real-time
// loop never waits for an output.
template <typename T, std::size_t Capacity>
class SpscRing {
  static_assert(std::has_single_bit(Capacity), "capacity must be a power of two");
  static_assert(std::is_trivially_copyable_v<T>, "items are copied by value");

 public:
  static constexpr std::size_t capacity() noexcept { return Capacity; }

  // Producer only. False when full: the item is dropped and counted.
  bool try_push(const T& item) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= Capacity) {
      dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      return false;
    }
    slots_[head & (Capacity - 1)] = item;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer only. False when empty.
  bool try_pop(T& out) noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    out = slots_[tail & (Capacity - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Any thread; exact only when both sides are idle.
  std::size_t size() const noexcept {
    return static_cast<std::size_t>(head_.load(std::memory_order_acquire) -
                                    tail_.load(std::memory_order_acquire));
  }
  // Items refused because the ring was full (any thread).
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  // Items ever accepted (any thread).
  std::uint64_t pushed() const noexcept { return head_.load(std::memory_order_relaxed); }

 private:
  // Head and tail on their own cache lines, so the two threads do not
  // invalidate each other's line on every item.
  alignas(64) std::atomic<std::uint64_t> head_{0};
  alignas(64) std::atomic<std::uint64_t> tail_{0};
  alignas(64) std::atomic<std::uint64_t> dropped_{0};
  std::array<T, Capacity> slots_{};
};

}  // namespace gyrotc::app
