// The best design as a ready-to-simulate scene file.
#pragma once

#include <string>

#include "vinci/design/spec.h"

namespace vinci::design {

/// The spec's scene file text with the design values `x` written into the fields they name
/// (friction, masses, support friction, shape sizes and scales, motion velocities and
/// harmonics, body poses) and stepper.duration set to spec.duration. The result parses with
/// sim::ParseScene (comments of the original file are not kept). Throws std::invalid_argument
/// if a value cannot be placed.
std::string BestSceneYaml(const DesignSpec& spec, const VectorXd& x);

}  // namespace vinci::design
