// Small JSON writing helpers shared by the subcommands that write result files.
#pragma once

#include <string>

namespace vinci::cli {

/// A JSON string literal (RFC 8259): quotes, backslashes and control characters escaped, and
/// '<', '>', '&' written as \u escapes so the text is also safe inside an HTML <script> element
/// (`vinci view`); other bytes pass through (names and messages are expected to be UTF-8).
std::string JsonString(const std::string& text);

}  // namespace vinci::cli
