#pragma once

#include <string>

namespace gyrotc::text {

// printf-style formatting into a string as long as the text needs (no fixed
// buffer to truncate a long path or message). The compiler checks the
// arguments against the format, as it checks printf's (-Wformat).
[[gnu::format(printf, 1, 2)]] std::string printf_string(const char* format, ...);

}  // namespace gyrotc::text
