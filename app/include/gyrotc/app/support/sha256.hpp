#pragma once

#include <string>
#include <string_view>

namespace gyrotc::app {

// SHA-256 (FIPS 180-4) of bytes, as 64 lowercase hex digits: what
// `sha256sum FILE` prints, so a user can tell which calibration file a unit
// runs with.
std::string sha256_hex(std::string_view bytes);

}  // namespace gyrotc::app
