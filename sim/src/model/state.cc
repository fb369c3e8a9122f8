#include "vinci/sim/model/state.h"

#include <stdexcept>

namespace vinci::sim {

const char* ToString(StepStatus status) {
  switch (status) {
    case StepStatus::kOk:
      return "ok";
    case StepStatus::kPenetration:
      return "penetration";
    case StepStatus::kSolverFailed:
      return "solver failed";
    case StepStatus::kNonFinite:
      return "non-finite";
    case StepStatus::kGeometryFailed:
      return "geometry failed";
  }
  throw std::logic_error("ToString: unknown StepStatus");
}

}  // namespace vinci::sim
