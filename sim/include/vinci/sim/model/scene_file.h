// Loading scenes from YAML files (format: docs/scene-format.md).
#pragma once

#include <string>

#include "vinci/sim/model/scene.h"

namespace vinci::sim {

/// Parses a scene from YAML text. `source_name` (a file name) prefixes error messages.
/// Throws std::invalid_argument with "<source>:<line>: <field path>: <what was expected>, got
/// <what was found>" for unknown keys, wrong types, negative/zero masses, non-finite numbers,
/// dt ≤ 0, dangling body/material names, and every other inconsistency. The returned scene is
/// finalized (Scene::Finalize).
Scene ParseScene(const std::string& yaml_text, const std::string& source_name = "<string>");

/// Reads and parses a scene file. Throws std::invalid_argument if it cannot be read.
Scene LoadSceneFile(const std::string& path);

}  // namespace vinci::sim
