// The 2.5D support-friction rows of one step (the equations are in model/support.h and
// docs/formulations.md §6).
#pragma once

#include <vector>

#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"
#include "vinci/sim/model/support.h"

namespace vinci::sim {

/// The support-friction rows of one step at x.
struct SupportRows {
  MatrixXd G_s;    ///< nv × (Σ columns): column [d; (p − c) × d] per direction (or x, y axis)
  VectorXd limit;  ///< h μ_s N_k per point (impulse radius of its disk)
  VectorXd hN;     ///< h N_k per point (= ∂limit/∂μ_s)
  std::vector<int> body;   ///< body index per point
  std::vector<int> first;  ///< first column of each point in G_s
  std::vector<int> count;  ///< columns per point: n_d (linearized) or 2 (quadratic: x, y)
  int points() const { return static_cast<int>(limit.size()); }
  int columns() const { return static_cast<int>(G_s.cols()); }
};

/// The support rows of all dynamic bodies of `model` at x for a step of length h. `quadratic`
/// selects the exact disk's two axis columns instead of the n_d linearized directions.
SupportRows AssembleSupport(const Scene& model, const State& x, double h, bool quadratic);
/// AssembleSupport into *out, reusing its storage.
void AssembleSupportInto(const Scene& model, const State& x, double h, bool quadratic,
                         SupportRows* out);

}  // namespace vinci::sim
