// Reading a user's input file (scene, field spec, LCP, vector) with a bound on its size.
#pragma once

#include <cstddef>
#include <string>

namespace vinci::sim {

/// The largest input file any reader accepts (64 MiB; docs/scene-format.md, "Limits"). A
/// scene of 10,000 bodies is ~2 MB, an LCP file of n = 2000 (dense M) ~ 40 MB.
constexpr std::size_t kMaxInputFileBytes = std::size_t{64} << 20;

/// The whole content of `path`. Throws std::invalid_argument naming the path and `what`
/// ("scene file", "LCP file", ...) when the file cannot be opened or read, is a directory or a
/// device (/dev/zero would never end), or holds more than `max_bytes` bytes (checked while
/// reading, so a pipe is bounded too).
std::string ReadInputFile(const std::string& path, const std::string& what,
                          std::size_t max_bytes = kMaxInputFileBytes);

}  // namespace vinci::sim
