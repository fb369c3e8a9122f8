// Private helpers shared by the complementarity solvers' sources.
#pragma once

#include <cstdio>
#include <string>

namespace vinci::sim::internal {

/// A number in short form (3 significant digits) for solver messages.
inline std::string FormatDouble(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g", v);
  return buf;
}

}  // namespace vinci::sim::internal
