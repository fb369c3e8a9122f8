#include "vinci/design/grip.h"

#include <algorithm>

#include "vinci/sim/formulations/contact.h"

namespace vinci::design {

std::vector<double> JawOverlaps(const sim::Scene& model, const sim::State& s, int body,
                                const std::vector<int>& jaws) {
  const std::vector<sim::BodyKinematics> kin = sim::ComputeBodyKinematics(model, s);
  std::vector<sim::Contact> contacts;
  sim::FindContacts(model, kin, model.options.envelope, &contacts);
  std::vector<double> overlaps(jaws.size(), 0.0);
  for (const sim::Contact& c : contacts) {
    int other = -1;
    if (c.body_a == body) other = c.body_b;
    if (c.body_b == body) other = c.body_a;
    if (other < 0) continue;
    const double gap = c.point.corner ? std::max(c.point.gap, c.point.gap2) : c.point.gap;
    for (std::size_t j = 0; j < jaws.size(); ++j)
      if (jaws[j] == other) overlaps[j] = std::max(overlaps[j], -gap);
  }
  return overlaps;
}

bool IsGripped(const Grip& grip, const std::vector<double>& overlaps) {
  if (overlaps.empty()) return false;
  const auto [lo, hi] = std::minmax_element(overlaps.begin(), overlaps.end());
  return *lo >= grip.min_overlap && *hi <= grip.max_overlap;
}

}  // namespace vinci::design
