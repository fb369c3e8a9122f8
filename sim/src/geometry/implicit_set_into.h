// MakeImplicitSet into kept storage (internal header): for a stepper that rebuilds the implicit
// sets of a scene's shapes on every step.
#pragma once

#include "vinci/sim/geometry/implicit_surface.h"

namespace vinci::sim {

/// MakeImplicitSet into *out, reusing the storage of its vectors (*out is unspecified if it
/// throws).
void MakeImplicitSetInto(const Shape& shape, ImplicitSet* out);

}  // namespace vinci::sim
