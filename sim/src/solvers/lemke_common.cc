// The options check and the power-of-two scale factors shared by the dense and sparse Lemke
// solvers (lemke_internal.h).
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "lemke_internal.h"
#include "solver_util.h"

namespace vinci::sim::internal::lemke {

void ValidateOptions(const LemkeOptions& o) {
  auto fail = [](const std::string& field, double value, const char* expected) {
    throw std::invalid_argument("LemkeOptions." + field + " = " + FormatDouble(value) +
                                "; expected " + expected);
  };
  if (o.max_pivots < 0) fail("max_pivots", o.max_pivots, ">= 0");
  if (!(o.pivot_tolerance >= 0.0) || !std::isfinite(o.pivot_tolerance)) {
    fail("pivot_tolerance", o.pivot_tolerance, "a finite value >= 0");
  }
  if (!(o.residual_tolerance >= 0.0) || !std::isfinite(o.residual_tolerance)) {
    fail("residual_tolerance", o.residual_tolerance, "a finite value >= 0");
  }
  if (!(o.regularization >= 0.0) || !std::isfinite(o.regularization)) {
    fail("regularization", o.regularization, "a finite value >= 0");
  }
  if (o.refactor_interval < 0) fail("refactor_interval", o.refactor_interval, ">= 0");
}

// −trunc(½·log2 m) for a finite m > 0, without a call to log2 where the result cannot depend
// on its rounding: with m = f·2^e, f ∈ [1, 2), and f at least 2^-22 away from 1 and 2,
// ½·log2 m lies strictly between e/2 and (e+1)/2 (its rounding error is below 1e-12), so its
// truncation is floor(e/2) for e ≥ 0 and floor(e/2) + 1 for e < 0; for f = 1 it is trunc(e/2).
// Otherwise (f near 1 or 2, subnormal m) std::log2 decides as before. Checked against the log2
// formula on 2·10⁷ values (log-uniform over the range of double, and next to every power of two).
int MinusTruncHalfLog2(double m) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &m, sizeof bits);
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  const std::uint64_t frac = bits & ((std::uint64_t{1} << 52) - 1);
  constexpr std::uint64_t kMargin = std::uint64_t{1} << 30;  // f − 1, 2 − f ≥ 2^-22
  const int e = biased - 1023;
  // A power of two (entries ±1 are common): log2 is exact (checked for every normal one).
  if (biased != 0 && biased != 0x7ff && frac == 0) return -(e / 2);
  if (biased != 0 && biased != 0x7ff && frac > kMargin &&
      frac < (std::uint64_t{1} << 52) - kMargin) {
    const int floor_half = e >= 0 ? e / 2 : -((1 - e) / 2);
    return -(e >= 0 ? floor_half : floor_half + 1);
  }
  return -static_cast<int>(std::trunc(0.5 * std::log2(m)));
}

// 2^k, exactly std::ldexp(1, k); built from its bits for normal results.
double PowerOfTwo(int k) {
  if (k < -1022 || k > 1023) return std::ldexp(1.0, k);
  const std::uint64_t bits = static_cast<std::uint64_t>(k + 1023) << 52;
  double v = 0.0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

}  // namespace vinci::sim::internal::lemke
