#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace gyrotc::app {

// A single-writer sequence lock: hands a small plain struct (a temperature
// reading, the loop's statistics) from one thread to others without locks.
// The writer never waits. A reader copies the value and checks that no write
// overlapped the copy; try_load() makes one attempt, so the real-time thread
// can read without ever spinning behind a preempted writer.
//
// The value is kept as relaxed atomic words (not a plain T), so concurrent
// access is well defined C++ and clean under the sanitizers.
template <typename T>
class Seqlock {
  static_assert(std::is_trivially_copyable_v<T>, "the value is copied word by word");
  static constexpr std::size_t kWords = (sizeof(T) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);

 public:
  Seqlock() noexcept { store_words(T{}); }

  // Writer only (one thread).
  void store(const T& value) noexcept {
    const std::uint64_t seq = seq_.load(std::memory_order_relaxed);
    seq_.store(seq + 1, std::memory_order_relaxed);  // odd: write in progress
    std::atomic_thread_fence(std::memory_order_release);
    store_words(value);
    seq_.store(seq + 2, std::memory_order_release);
  }

  // One attempt: false if a write overlapped (try again later). On success
  // `version`, if given, is the number of stores the value reflects (0 = the
  // initial T{}), so a reader can tell a new value from one it has seen.
  bool try_load(T& out, std::uint64_t* version = nullptr) const noexcept {
    const std::uint64_t before = seq_.load(std::memory_order_acquire);
    if ((before & 1U) != 0) return false;
    std::array<std::uint64_t, kWords> words;
    for (std::size_t i = 0; i < kWords; ++i) words[i] = data_[i].load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (seq_.load(std::memory_order_relaxed) != before) return false;
    std::memcpy(static_cast<void*>(&out), words.data(), sizeof(T));  // T is trivially copyable
    if (version != nullptr) *version = before / 2;
    return true;
  }

  // Retries until a consistent copy is read. Not for the real-time thread.
  T load(std::uint64_t* version = nullptr) const noexcept {
    T out{};
    while (!try_load(out, version)) {
    }
    return out;
  }

  // Number of completed stores (any thread).
  std::uint64_t version() const noexcept { return seq_.load(std::memory_order_acquire) / 2; }

 private:
  void store_words(const T& value) noexcept {
    std::array<std::uint64_t, kWords> words{};
    std::memcpy(words.data(), &value, sizeof(T));
    for (std::size_t i = 0; i < kWords; ++i) data_[i].store(words[i], std::memory_order_relaxed);
  }

  std::atomic<std::uint64_t> seq_{0};
  std::array<std::atomic<std::uint64_t>, kWords> data_;
};

}  // namespace gyrotc::app
