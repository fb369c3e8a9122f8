// `mpirun -np N vinci design|field`: the parts of the two commands that run over MPI ranks
// (vinci/parallel). Rank 0 runs the command as usual with a distributed map; the other ranks
// build the same problem from the same command line and serve rank 0's chunks. A worker never
// prints and never writes files: if its own setup fails it serves that error to rank 0.
#pragma once

#include <functional>
#include <memory>

#include "command.h"
#include "design_command.h"
#include "vinci/parallel/distributor.h"
#include "vinci/sim/plate/velocity_field.h"

namespace vinci::cli {

/// Ranks > 0 of `vinci design`: loads the spec as rank 0 does and serves its evaluations
/// (design::DistributedEvaluator) until rank 0 stops. Returns kOk.
ExitCode ServeDesign(const DesignOptions& options, parallel::Distributor& ranks);

/// Rank 0 of `vinci field` under mpirun: sim::ComputeVelocityField with the grid points spread
/// over the ranks (each rank on options.threads threads). Bit-identical to it.
sim::VelocityField DistributedVelocityField(parallel::Distributor& ranks,
                                            const sim::Simulator& simulator,
                                            const sim::Params& params, const sim::FieldSpec& spec,
                                            const sim::FieldOptions& options);

/// What `vinci field` computes: the simulator (scene, --dt) and the field spec (the file's
/// `field:` section with the flags applied, validated).
struct FieldSetup {
  std::unique_ptr<sim::Simulator> simulator;
  sim::FieldSpec spec;
};

/// Ranks > 0 of `vinci field`: `setup` builds the simulator and spec exactly as rank 0 does;
/// then serves rank 0's grid points until it stops. Returns kOk.
ExitCode ServeField(const std::function<FieldSetup()>& setup, int threads,
                    parallel::Distributor& ranks);

}  // namespace vinci::cli
