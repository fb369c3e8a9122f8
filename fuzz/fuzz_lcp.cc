// Fuzz target: LCP text → ParseLcp → every LCP solver, each answer checked independently
// (issue 18, deliverable 2).
//
// A malformed file must end in std::invalid_argument; a solver must return a status (never
// throw), and whenever it says "solved" its z must pass the check below, written here without
// the solvers' code: z and w = Mz + q finite, their negative parts and min(z_i, w_i) small
// relative to each row's own scale (s_i = max(|q_i| + Σ_j |M_ij||z_j|, s_z Σ_j |M_ij|, 1e-8 s_w)
// with s_w = max_i s_i of the first two terms and s_z = max(‖z‖∞, ‖q‖∞ / ‖M‖∞)): a row written
// in much smaller units than the others is judged in its own (fuzz/crashes/lcp/
// lemke_fb_row_scaled.lcp). A violation aborts, which libFuzzer and the replay test report.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_file.h"

namespace {

constexpr int kMaxSize = 40;             // keeps each execution short
constexpr double kSignTolerance = 1e-5;  // looser than every solver's acceptance (1e-6)

[[noreturn]] void Finding(const std::string& solver, const std::string& what) {
  std::fprintf(stderr, "fuzz_lcp: solver '%s' reported solved but %s\n", solver.c_str(),
               what.c_str());
  std::abort();
}

void CheckSolved(const vinci::sim::LcpProblem& p, const Eigen::VectorXd& z,
                 const std::string& solver) {
  const Eigen::Index n = p.q.size();
  if (z.size() != n) Finding(solver, "z has the wrong size");
  if (!z.allFinite()) Finding(solver, "z is not finite");
  double q_norm = 0.0, m_norm = 0.0, z_norm = 0.0;
  Eigen::VectorXd row(n), row_z(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    q_norm = std::max(q_norm, std::abs(p.q(i)));
    z_norm = std::max(z_norm, std::abs(z(i)));
    row(i) = 0.0;
    row_z(i) = std::abs(p.q(i));
    for (Eigen::Index j = 0; j < n; ++j) {
      row(i) += std::abs(p.M(i, j));
      row_z(i) += std::abs(p.M(i, j) * z(j));
    }
    m_norm = std::max(m_norm, row(i));
  }
  const double s_z = std::max(z_norm, m_norm > 0.0 ? q_norm / m_norm : 0.0);
  double s_w = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) s_w = std::max({s_w, row_z(i), s_z * row(i)});
  for (Eigen::Index i = 0; i < n; ++i) {
    double w = p.q(i);
    for (Eigen::Index j = 0; j < n; ++j) w += p.M(i, j) * z(j);
    if (!std::isfinite(w)) Finding(solver, "w is not finite");
    const double s_i = std::max({row_z(i), s_z * row(i), 1e-8 * s_w});
    const double zr = s_z > 0.0 ? z(i) / s_z : 0.0, wr = s_i > 0.0 ? w / s_i : 0.0;
    if (zr < -kSignTolerance || wr < -kSignTolerance)
      Finding(solver, "z or w is negative at " + std::to_string(i));
    if (std::min(std::abs(zr), std::abs(wr)) > kSignTolerance)
      Finding(solver, "z and w are not complementary at " + std::to_string(i));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  vinci::sim::LcpProblem problem;
  try {
    problem = vinci::sim::ParseLcp(text, "fuzz.lcp");
  } catch (const std::invalid_argument&) {
    return 0;
  }
  if (problem.size() > kMaxSize) return 0;
  for (const std::string& name : vinci::sim::LcpSolverNames()) {
    Eigen::VectorXd z;
    const vinci::sim::SolverReport r = vinci::sim::MakeLcpSolver(name)->Solve(problem, nullptr, &z);
    if (r.ok()) CheckSolved(problem, z, name);
  }
  return 0;
}
