#pragma once
// Include this instead of a Catch2 header: it picks v2 (Debian 12) or v3
// (Debian 13, Yocto walnascar), so the tests are written once for both.
#if defined(GYROTC_CATCH3)
#include <catch2/catch_approx.hpp>
#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>
#include <catch2/matchers/catch_matchers_string.hpp>

#include <string>

using Catch::Approx;
namespace Catch {
// v2's name for the substring matcher, which v3 calls ContainsSubstring.
inline Matchers::StringContainsMatcher Contains(const std::string& text) {
  return Matchers::ContainsSubstring(text);
}
}  // namespace Catch
#else
#include <catch2/catch.hpp>
#endif
