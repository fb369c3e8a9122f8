// Numbers and user text in messages: compact, and safe to print on a terminal or in a CSV.
#pragma once

#include <string>

namespace vinci::sim {

/// A number for a message, %g-style with 6 significant digits: "1e-13", "0.001", "-1e+308",
/// "inf" (std::to_string would print 1e-13 as "0.000000" and 1e308 with 309 digits).
std::string FormatNumber(double v);

/// `text` with every byte that is not printable ASCII or part of valid UTF-8 (control
/// characters such as ESC, invalid UTF-8, C1 controls U+0080..U+009F) replaced by "\xNN", so a
/// scene's raw bytes and terminal escape sequences never reach a terminal. Newlines are kept
/// if `keep_newlines`.
std::string EscapeText(const std::string& text, bool keep_newlines = false);

/// True if `text` is non-empty and EscapeText would leave it unchanged and it contains none of
/// `,` `"` (the characters that would break a CSV header).
bool IsPrintableName(const std::string& text);

}  // namespace vinci::sim
