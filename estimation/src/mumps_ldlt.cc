// Sequential MUMPS as a symmetric indefinite LDLᵀ (mumps_ldlt.h).
#include "mumps_ldlt.h"

#include <dmumps_c.h>

#include <limits>
#include <vector>

namespace vinci::estimation::mpec_internal {

namespace {
// MUMPS' 1-based control and information arrays.
constexpr int kUseCommWorld = -987654;  // the sequential library's stand-in communicator
int& Icntl(DMUMPS_STRUC_C& id, int i) { return id.icntl[i - 1]; }

// A sequential symmetric (not necessarily definite) instance without any output; false if
// MUMPS failed.
bool InitSymmetric(DMUMPS_STRUC_C& id) {
  id.job = -1;
  id.par = 1;
  id.sym = 2;
  id.comm_fortran = kUseCommWorld;
  dmumps_c(&id);
  if (id.infog[0] < 0) return false;
  Icntl(id, 1) = -1;  // no error, diagnostic or statistics output
  Icntl(id, 2) = -1;
  Icntl(id, 3) = -1;
  Icntl(id, 4) = 0;
  return true;
}
}  // namespace

struct MumpsLdlt::Impl {
  DMUMPS_STRUC_C id{};
  bool initialized = false, factored = false;
  std::vector<MUMPS_INT> irn, jcn;
  std::vector<double> a;
  std::vector<double> rhs;
};

MumpsLdlt::MumpsLdlt() : impl_(std::make_unique<Impl>()) {}

MumpsLdlt::~MumpsLdlt() {
  if (impl_->initialized) {
    impl_->id.job = -2;
    dmumps_c(&impl_->id);
  }
}

bool MumpsLdlt::Compute(const sim::SparseMatrixXd& K) {
  Impl& m = *impl_;
  DMUMPS_STRUC_C& id = m.id;
  if (!m.initialized) {
    if (!InitSymmetric(id)) return false;
    m.initialized = true;
  }
  m.factored = false;
  m.irn.clear();
  m.jcn.clear();
  m.a.clear();
  for (int c = 0; c < K.outerSize(); ++c) {
    for (sim::SparseMatrixXd::InnerIterator it(K, c); it; ++it) {
      if (it.row() < it.col()) continue;
      m.irn.push_back(static_cast<MUMPS_INT>(it.row() + 1));
      m.jcn.push_back(static_cast<MUMPS_INT>(it.col() + 1));
      m.a.push_back(it.value());
    }
  }
  id.n = static_cast<MUMPS_INT>(K.rows());
  id.nnz = static_cast<MUMPS_INT8>(m.a.size());
  id.irn = m.irn.data();
  id.jcn = m.jcn.data();
  id.a = m.a.data();
  Icntl(id, 7) = 6;    // QAMD ordering: deterministic
  Icntl(id, 24) = 1;   // null pivot detection
  Icntl(id, 14) = 50;  // working storage beyond the analysis' estimate, percent
  for (int attempt = 0; attempt < 3; ++attempt) {
    id.job = 4;  // analysis and factorization
    dmumps_c(&id);
    if (id.infog[0] >= 0) {
      m.factored = true;
      return true;
    }
    if (id.infog[0] != -9 && id.infog[0] != -8) return false;  // not a storage shortfall
    Icntl(id, 14) *= 4;
  }
  return false;
}

sim::VectorXd MumpsLdlt::solve(const sim::VectorXd& b) const {
  Impl& m = *impl_;
  m.rhs.assign(b.data(), b.data() + b.size());
  m.id.rhs = m.rhs.data();
  m.id.nrhs = 1;
  m.id.lrhs = m.id.n;
  m.id.job = 3;
  dmumps_c(&m.id);
  if (m.id.infog[0] < 0)
    return sim::VectorXd::Constant(b.size(), std::numeric_limits<double>::quiet_NaN());
  return Eigen::Map<const sim::VectorXd>(m.rhs.data(), b.size());
}

int MumpsLdlt::null_pivots() const { return impl_->factored ? impl_->id.infog[27] : 0; }

double EstimatedFactorizationFlops(int n, const std::vector<std::pair<int, int>>& lower,
                                   int ordering) {
  DMUMPS_STRUC_C id{};
  if (!InitSymmetric(id)) return std::numeric_limits<double>::quiet_NaN();
  std::vector<MUMPS_INT> irn, jcn;
  irn.reserve(lower.size());
  jcn.reserve(lower.size());
  for (const auto& [r, c] : lower) {
    irn.push_back(static_cast<MUMPS_INT>(r + 1));
    jcn.push_back(static_cast<MUMPS_INT>(c + 1));
  }
  id.n = static_cast<MUMPS_INT>(n);
  id.nnz = static_cast<MUMPS_INT8>(irn.size());
  id.irn = irn.data();
  id.jcn = jcn.data();
  Icntl(id, 6) = 0;  // no maximum matching: it needs the values, which a pattern has not
  Icntl(id, 7) = ordering;
  id.job = 1;
  dmumps_c(&id);
  const double flops = id.infog[0] < 0 ? std::numeric_limits<double>::quiet_NaN()
                                       : static_cast<double>(id.rinfog[0]);
  id.job = -2;
  dmumps_c(&id);
  return flops;
}

}  // namespace vinci::estimation::mpec_internal
