#pragma once
// The message of the InputError that calling f throws, or "" when it throws
// none: tests compare it with the one-line error a user would see.

#include <string>
#include <utility>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::test {

template <class F>
std::string input_error_of(F&& f) {
  try {
    std::forward<F>(f)();
  } catch (const gyrotc::app::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace gyrotc::test
