#include "vinci/sim/formulations/first_order.h"

#include <stdexcept>

#include "vinci/sim/formulations/stewart_trinkle.h"

namespace vinci::sim {

std::unique_ptr<Formulation> MakeFirstOrder(const StepperOptions& options) {
  if (options.formulation != FormulationType::kFirstOrder)
    throw std::invalid_argument("MakeFirstOrder: options.formulation is not kFirstOrder");
  return std::make_unique<StewartTrinkle>(options,
                                          MakeLcpSolver(options.solver, options.solver_options));
}

}  // namespace vinci::sim
