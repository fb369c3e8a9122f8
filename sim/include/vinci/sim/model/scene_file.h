// Loading scenes from YAML files (format: docs/scene-format.md).
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"

namespace vinci::sim {

/// Limits the loader enforces (docs/scene-format.md, "Limits"), each with a file:line message.
/// The input file itself is limited to kMaxInputFileBytes (solvers/input_file.h).
struct SceneLimits {
  /// Smallest size (m: radius, half extent, semi-axis, half length) or mass (kg) a scene may
  /// have: the lower bound of those entries in the parameter table (Scene::Finalize), so that
  /// a scene the loader accepts also passes Scene::ApplyParams.
  static constexpr double kMinSize = 1e-12;
  /// Bodies per scene. The LCP steppers (Stewart–Trinkle, Anitescu–Potra, first-order, NCP)
  /// keep the mass matrix block diagonal and find contact pairs by sweep and prune, so memory
  /// and work per step grow with the bodies and the contacts, not with the bodies squared.
  static constexpr int kMaxBodies = 10000;
  /// Bodies per scene for the steppers whose Newton systems are dense in ν (geometrically
  /// implicit, quasistatic-dlc/dqc, dynamic-dqc: nv × nv matrices, ~0.3 GB at 1000 bodies);
  /// checked when the simulator is built (CheckSceneSupported).
  static constexpr int kMaxDenseBodies = 1000;
  /// stepper.friction_directions (n_d, even): each contact adds n_d + 2 LCP rows.
  static constexpr int kMaxFrictionDirections = 64;
  /// support.directions of a 2.5D support (limit-surface linearization).
  static constexpr int kMaxSupportDirections = 1024;
  /// Vertices of a convex polygon or a concave polygon (planar collision is O(n·m)).
  static constexpr int kMaxPolygonVertices = 1000;
  /// Vertices of a polyhedron (its hull is computed once, O(n log n) by qhull).
  static constexpr int kMaxPolyhedronVertices = 10000;
};

/// Parses a scene from YAML text. `source_name` (a file name) prefixes error messages.
/// Throws std::invalid_argument with "<source>:<line>: <field path>: <what was expected>, got
/// <what was found>" for unknown keys, wrong types, negative/zero masses, non-finite numbers,
/// dt ≤ 0, dangling body/material names, and every other inconsistency. The returned scene is
/// finalized (Scene::Finalize).
Scene ParseScene(const std::string& yaml_text, const std::string& source_name = "<string>");

/// Warnings about a valid scene that will be slow or surprising, one sentence each (the
/// library prints nothing; the CLI prints them as "vinci: warning: ..."). Today: an
/// stepper.envelope larger than the bounding radius of the smallest bounded shape, which makes
/// every nearby pair of shapes a contact in every step (an envelope of 1 m among boxes of
/// 0.2 m gives ~1000 contacts per step).
std::vector<std::string> SceneWarnings(const Scene& scene);

/// Reads and parses a scene file. Throws std::invalid_argument if it cannot be read.
Scene LoadSceneFile(const std::string& path);

}  // namespace vinci::sim
