// Scene files of the box benchmarks, shared by vinci_vs_mujoco and step_profile (header only).
#pragma once

#include <cstdio>
#include <sstream>
#include <string>

namespace vinci::bench {

/// x written with `digits` significant digits (17: round-trips every double exactly).
inline std::string Num(double x, int digits = 17) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", digits, x);
  return buf;
}

/// YAML of a resting stack of k 0.2 m cubes (1 kg) on a floor, as box_stack.yaml (μ = 0.6,
/// n_d = 4, dt = 1 ms, envelope 2 mm). Box i's centre is at height 0.1 + 0.2 i written with
/// `digits` significant digits (17: the double 0.1 + 0.2 * i exactly, so faces touch to within
/// round-off; 6: the nearest double to the decimal, as a hand-written scene file). With gap > 0
/// the cubes start that far (m) apart and above the floor, so the stack settles through impacts.
inline std::string StackYaml(int k, int digits = 17, double gap = 0.0) {
  std::ostringstream s;
  s << "name: stack" << k << "\ndimension: 3\n"
    << "stepper: {dt: 0.001, duration: 2.0, friction_directions: 4, envelope: 0.002}\n"
    << "friction: {default: 0.6}\nbodies:\n"
    << "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n";
  for (int i = 0; i < k; ++i)
    s << "  - {name: box" << i << ", mass: 1.0, pose: {position: [0, 0, "
      << Num(0.1 + gap + (0.2 + gap) * i, digits)
      << "]}, shapes: [{type: box, half_extents: [0.1, 0.1, 0.1]}]}\n";
  return s.str();
}

/// YAML of a pile of layers × side × side cubes (default 4 × 5 × 5 = 100): `layers` layers of
/// side × side 0.2 m cubes (1 kg) 5 mm apart (no side contacts), odd layers shifted by (5, 5) cm,
/// so each cube above the floor rests on one to four cubes below; μ = 0.6, n_d = 4, dt = 1 ms,
/// envelope 2 mm.
inline std::string PileYaml(int digits = 17, int layers = 4, int side = 5, double gap = 0.0) {
  std::ostringstream s;
  s << "name: pile" << layers * side * side << "\ndimension: 3\n"
    << "stepper: {dt: 0.001, duration: 2.0, friction_directions: 4, envelope: 0.002}\n"
    << "friction: {default: 0.6}\nbodies:\n"
    << "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n";
  for (int layer = 0; layer < layers; ++layer)
    for (int i = 0; i < side; ++i)
      for (int j = 0; j < side; ++j) {
        const double shift = layer % 2 ? 0.05 : 0.0;
        s << "  - {name: b" << layer << "_" << i << "_" << j << ", mass: 1.0, pose: {position: ["
          << Num(0.205 * i + shift, digits) << ", " << Num(0.205 * j + shift, digits) << ", "
          << Num(0.1 + gap + (0.2 + gap) * layer, digits)
          << "]}, shapes: [{type: box, half_extents: [0.1, 0.1, 0.1]}]}\n";
      }
  return s.str();
}

}  // namespace vinci::bench
