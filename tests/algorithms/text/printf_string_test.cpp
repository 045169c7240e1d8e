#include "gyrotc/algorithms/text/printf_string.hpp"

#include <string>

#include "gyrotc_catch.hpp"

using gyrotc::text::printf_string;

TEST_CASE("printf_string formats as printf does") {
  CHECK(printf_string("casing %.2f C, TEC %+.2f A, %s", 55.0, -0.5, "holding") ==
        "casing 55.00 C, TEC -0.50 A, holding");
}

TEST_CASE("printf_string returns a text longer than any fixed buffer whole") {
  // The helpers it replaced cut their messages at 256 and 320 characters.
  const std::string path(1000, 'p');
  const std::string text = printf_string("%s: line %d", path.c_str(), 12);
  CHECK(text.size() == 1009);
  CHECK(text.substr(1000) == ": line 12");
}

TEST_CASE("printf_string of an empty text is empty") { CHECK(printf_string("%s", "").empty()); }
