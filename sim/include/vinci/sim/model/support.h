// The 2.5D model: friction between planar bodies and the plane of motion (docs/formulations.md §6).
//
// A planar dynamic body rests on the plane of motion through support points s_k (body frame)
// carrying normal forces N_k ≥ 0 (Body::support). Each point has a friction disk of radius
// μ_s N_k. Over a step of length h its friction impulse p_s,k opposes the slip of the point:
//
//   linearized (LCP, n_d directions d_j = (cos 2πj/n_d, sin 2πj/n_d) fixed in the world):
//     0 ≤ p_s ⊥ G_sᵀ ν_ℓ+1 + E_s σ_s ≥ 0
//     0 ≤ σ_s ⊥ h μ_s N − E_sᵀ p_s ≥ 0
//   exact (quadratic disk, an NCP; p_s,k = (p_x, p_y) free, u_k = velocity of the point):
//     0 = u_k + σ_s,k p_s,k / (h μ_s N_k)
//     0 ≤ σ_s,k ⊥ ((h μ_s N_k)² − |p_s,k|²) / (h μ_s N_k) ≥ 0
//   (the §2 quadratic-cone rows divided by h μ_s N_k, so every row has the scale of a velocity
//   or an impulse; a point with N_k = 0 has no friction: p_s,k = 0, σ_s,k = 0).
//
// Normal forces are given, or computed by a static distribution (ComputeSupportFractions):
// Σ N_k = m g cos(tilt) and Σ N_k s_k = 0 (no moment about the centre of mass, the body
// origin). With ≤ 3 non-collinear points this is the statically determinate solution; with
// more points (or collinear ones) it is the minimum-norm distribution with N ≥ 0.
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"

namespace vinci::sim {

/// Static load fractions f_k ≥ 0 with Σ f_k = 1 and Σ f_k s_k = 0 (x, y of the body-frame
/// points; the centre of mass is the origin): the unique solution for 3 non-collinear points,
/// otherwise argmin ½‖f‖² subject to those equations and f ≥ 0. Throws std::invalid_argument
/// (prefixed with `context`) if no such f exists, i.e. the centre of mass is outside the convex
/// hull of the points.
std::vector<double> ComputeSupportFractions(const std::vector<Vector3d>& points_B,
                                            const std::string& context);

/// Checks every body's Support and fills the static load fractions. Called by Scene::Finalize.
/// Throws std::invalid_argument naming the body for: supports in a spatial scene or on a
/// non-dynamic body, μ_s < 0, n_d < 3, normal forces of the wrong count, negative or non-finite,
/// an impossible static distribution, or a plane tilt outside [0, π/2] or g ≤ 0; also a
/// quasistatic or dynamic-dqc formulation in a spatial scene.
void FinalizeSupports(Scene* scene);

/// N_k of a body's support points (N): the given forces, or f_k m g cos(tilt).
std::vector<double> SupportNormalForces(const Scene& scene, const Body& body);
/// SupportNormalForces into *N, reusing its storage.
void SupportNormalForcesInto(const Scene& scene, const Body& body, std::vector<double>* N);

/// True if any dynamic body of the scene has support points.
bool HasSupports(const Scene& scene);

}  // namespace vinci::sim
