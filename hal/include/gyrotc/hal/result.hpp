#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <optional>
#include <utility>
#include <variant>

// Errors as values: every device call returns a Status or a Result<T>.
// An Error keeps its message in a fixed buffer, so building one (e.g. a DRDY
// timeout on the real-time thread) neither allocates nor throws.
namespace gyrotc::hal {

enum class ErrorCode : std::uint8_t {
  io,             // a system call failed (errno_value says which)
  timeout,        // a wait ran out (DRDY edge, ...)
  not_found,      // a device path, chip, line or w1 directory is missing
  invalid_config, // a configuration that cannot work (and why)
  bad_data,       // a device answered, but with nonsense
  fault,          // a device reports a fault (or one was injected)
  busy,           // another process holds the device (ours must not touch it)
};

std::string_view to_string(ErrorCode code);

class Error {
 public:
  static constexpr std::size_t kMaxMessage = 223;

  // printf-style message, truncated to kMaxMessage characters.
  [[gnu::format(printf, 2, 3)]] static Error make(ErrorCode code, const char* format, ...) noexcept;
  // "<what> '<path>': <strerror(errno_value)>" with the errno kept.
  static Error from_errno(int errno_value, std::string_view what, std::string_view path) noexcept;

  ErrorCode code() const noexcept { return code_; }
  int errno_value() const noexcept { return errno_value_; }
  std::string_view message() const noexcept { return {text_.data(), length_}; }

 private:
  ErrorCode code_ = ErrorCode::io;
  int errno_value_ = 0;
  std::uint8_t length_ = 0;
  std::array<char, kMaxMessage + 1> text_;  // only the first length_ chars are set
};

// Either a T or an Error; only the one held is constructed (cheap on the
// per-sample path).
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) noexcept : v_(std::in_place_index<0>, std::move(value)) {}  // NOLINT: implicit by design
  Result(Error error) noexcept : v_(std::in_place_index<1>, error) {}         // NOLINT: implicit by design

  bool ok() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }
  // Only when ok().
  const T& value() const noexcept { return *std::get_if<0>(&v_); }
  T& value() noexcept { return *std::get_if<0>(&v_); }
  const T& operator*() const noexcept { return value(); }
  const T* operator->() const noexcept { return &value(); }
  // Only when !ok().
  const Error& error() const noexcept { return *std::get_if<1>(&v_); }

 private:
  std::variant<T, Error> v_;
};

// Success or an Error.
class [[nodiscard]] Status {
 public:
  Status() noexcept = default;
  Status(Error error) noexcept : error_(error) {}  // NOLINT: implicit by design
  static Status success() noexcept { return {}; }

  bool ok() const noexcept { return !error_.has_value(); }
  explicit operator bool() const noexcept { return ok(); }
  // Only when !ok().
  const Error& error() const noexcept { return *error_; }

 private:
  std::optional<Error> error_;
};

}  // namespace gyrotc::hal
