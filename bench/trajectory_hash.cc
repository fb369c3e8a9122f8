// trajectory_hash: a fingerprint of the trajectories of scene files, to check that a change to
// the step keeps every trajectory bit for bit (bench/README.md, "Small scenes").
//
//   trajectory_hash [--steps N] SCENE.yaml...
//
// For each scene: a rollout of N steps (default 300) from the scene's initial state with its
// default parameters; prints the scene, the number of steps done, whether the rollout succeeded
// and an FNV-1a hash of t, q, v and the warm start of every state. Run it before and after a
// change and compare the outputs (diff).
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace {

struct Fnv {
  std::uint64_t h = 1469598103934665603ull;
  void Add(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 1099511628211ull;
    }
  }
  void Add(const vinci::sim::VectorXd& v) {
    const long n = v.size();
    Add(&n, sizeof n);
    Add(v.data(), sizeof(double) * static_cast<std::size_t>(v.size()));
  }
};

}  // namespace

int main(int argc, char** argv) {
  int steps = 300;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--steps") == 0 && i + 1 < argc)
      steps = std::stoi(argv[++i]);
    else
      files.emplace_back(argv[i]);
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: trajectory_hash [--steps N] SCENE.yaml...\n");
    return 2;
  }
  for (const std::string& file : files) {
    try {
      const vinci::sim::Simulator sim(vinci::sim::LoadSceneFile(file));
      const vinci::sim::Trajectory traj =
          sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
      Fnv fnv;
      for (const vinci::sim::State& x : traj.states) {
        fnv.Add(&x.t, sizeof x.t);
        fnv.Add(x.q);
        fnv.Add(x.v);
        fnv.Add(x.warm_start);
      }
      std::printf("%s %zu %s %016llx\n", file.c_str(), traj.states.size(),
                  traj.ok ? "ok" : "failed", static_cast<unsigned long long>(fnv.h));
    } catch (const std::exception& e) {
      std::printf("%s error: %s\n", file.c_str(), e.what());
    }
  }
  return 0;
}
