// The minimum-norm spread of statically indeterminate normal impulses over a whole contact
// network (spread_normals.h, SpreadIndeterminateNormalsGlobally).
#include <algorithm>
#include <cmath>
#include <vector>

#include "spread_normals.h"
#include "vinci/sim/solvers/semidefinite_ldlt.h"

namespace vinci::sim::internal {
namespace {

// Rows of the touching normal columns J whose norm is below this fraction of the largest row
// norm are left out of J Jᵀ (a box's yaw row: normals ⟂ to the floor have no yaw lever, so
// the row is round-off; solving against it would divide round-off by round-off).
constexpr double kNegligibleRow = 1e-8;
// Pivots of J Jᵀ below this fraction of their diagonal are dependent (SemidefiniteLdlt).
constexpr double kDropTolerance = 1e-10;
// The spread is kept only if it leaves G_n p unchanged to this fraction of ‖G_n p‖∞ (a
// failed solve of J Jᵀ y = J p, e.g. an ill-conditioned network, leaves z as it is).
constexpr double kKeepVelocityTol = 1e-9;
// Rounds of the active-set loop (fixing negative minimum-norm impulses at 0).
constexpr int kMaxRounds = 12;
// An unloaded member whose (Jᵀy)_i is at most this fraction of ‖p‖∞ would take no load.
constexpr double kDualTol = 1e-9;

struct GlobalSpreadScratch {
  std::vector<int> members, row_of, rows, cursor;
  SpreadEligibility eligibility;
  std::vector<double> row_norm2;
  // J's columns (one per member) as (compressed row, value) over the kept rows.
  std::vector<int> col_start, col_row;
  std::vector<double> col_value;
  CompressedColumns A;
  std::vector<std::vector<std::pair<int, double>>> a_cols;
  SemidefiniteLdlt ldlt;
  std::vector<char> free;
  VectorXd p, target, dual, b, y, check;
};

}  // namespace

void SpreadIndeterminateNormalsGlobally(const Scene& model, const StewartTrinkle::Assembly& a,
                                        const VectorXd& v1, double h, bool velocity_level,
                                        double w_tol, VectorXd* z) {
  (void)model;
  const int nc = static_cast<int>(a.contacts.size());
  const int nf = nc * a.nd;
  if (nc < 2 || z->size() < nc + nf + nc) return;
  thread_local GlobalSpreadScratch s;
  s.eligibility.Reset(a);
  const auto eligible = [&](int c) {
    return s.eligibility.Eligible(a, v1, *z, c, h, velocity_level, w_tol);
  };
  s.members.clear();
  int unloaded = 0;
  for (int c = 0; c < nc; ++c)
    if (eligible(c)) {
      s.members.push_back(c);
      unloaded += !((*z)[c] > 0.0);
    }
  const int m = static_cast<int>(s.members.size());
  if (m < 2 || unloaded == 0) return;

  // Rows of J = G_n(:, members) and their norms; the kept rows get compressed indices.
  const int nv = static_cast<int>(a.G_n.rows());
  s.row_norm2.assign(nv, 0.0);
  for (int c : s.members)
    for (SparseMatrixd::InnerIterator it(a.G_n, c); it; ++it)
      s.row_norm2[it.row()] += it.value() * it.value();
  const double max_norm2 = *std::max_element(s.row_norm2.begin(), s.row_norm2.end());
  if (!(max_norm2 > 0.0) || !std::isfinite(max_norm2)) return;
  s.row_of.assign(nv, -1);
  s.rows.clear();
  for (int r = 0; r < nv; ++r)
    if (s.row_norm2[r] > kNegligibleRow * kNegligibleRow * max_norm2) {
      s.row_of[r] = static_cast<int>(s.rows.size());
      s.rows.push_back(r);
    }
  const int nr = static_cast<int>(s.rows.size());
  s.col_start.assign(1, 0);
  s.col_row.clear();
  s.col_value.clear();
  for (int c : s.members) {
    for (SparseMatrixd::InnerIterator it(a.G_n, c); it; ++it)
      if (const int r = s.row_of[it.row()]; r >= 0) {
        s.col_row.push_back(r);
        s.col_value.push_back(it.value());
      }
    s.col_start.push_back(static_cast<int>(s.col_row.size()));
  }
  // b = J p: the normal impulses' contribution to the velocity, to be kept.
  s.p.resize(m);
  s.b.setZero(nr);
  for (int i = 0; i < m; ++i) {
    s.p[i] = (*z)[s.members[i]];
    for (int k = s.col_start[i]; k < s.col_start[i + 1]; ++k)
      s.b[s.col_row[k]] += s.col_value[k] * s.p[i];
  }
  const double b_norm = s.b.lpNorm<Eigen::Infinity>();
  if (!(b_norm > 0.0)) return;

  // The minimum-norm impulses over the free members (s.free[i]) with J p = b, into s.target
  // (0 on the others); false if the solve fails or misses b.
  const auto min_norm = [&]() {
    if (static_cast<int>(s.a_cols.size()) < nr) s.a_cols.resize(nr);
    for (int r = 0; r < nr; ++r) s.a_cols[r].clear();
    for (int i = 0; i < m; ++i) {
      if (!s.free[i]) continue;
      for (int p = s.col_start[i]; p < s.col_start[i + 1]; ++p)
        for (int q = s.col_start[i]; q < s.col_start[i + 1]; ++q) {
          auto& col = s.a_cols[s.col_row[q]];
          const int r = s.col_row[p];
          const double v = s.col_value[p] * s.col_value[q];
          auto pos = std::lower_bound(col.begin(), col.end(), r,
                                      [](const auto& e, int key) { return e.first < key; });
          if (pos != col.end() && pos->first == r)
            pos->second += v;
          else
            col.insert(pos, {r, v});
        }
    }
    s.A.Reset(nr);
    for (int j = 0; j < nr; ++j) {
      for (const auto& [r, v] : s.a_cols[j]) {
        s.A.row.push_back(r);
        s.A.value.push_back(v);
      }
      s.A.col_start[j + 1] = static_cast<int>(s.A.row.size());
    }
    if (!s.ldlt.Factorize(s.A, kDropTolerance)) return false;
    s.ldlt.Solve(s.b, &s.y);
    s.target.setZero(m);
    s.dual.resize(m);
    s.check = -s.b;
    for (int i = 0; i < m; ++i) {
      double t = 0.0;
      for (int k = s.col_start[i]; k < s.col_start[i + 1]; ++k)
        t += s.col_value[k] * s.y[s.col_row[k]];
      s.dual[i] = t;
      if (!s.free[i]) continue;
      s.target[i] = t;
      for (int k = s.col_start[i]; k < s.col_start[i + 1]; ++k)
        s.check[s.col_row[k]] += s.col_value[k] * t;
    }
    return s.target.allFinite() && s.check.lpNorm<Eigen::Infinity>() <= kKeepVelocityTol * b_norm;
  };
  // First the loaded members alone: if their minimum-norm impulse is nonnegative and no
  // unloaded member would take load ((Jᵀy)_i ≤ 0 there: the optimality conditions of
  // min ‖p‖² s.t. J p = b, p ≥ 0), that is the answer (one factorization: a resting pile whose
  // previous step was spread).
  const double p_max = s.p.lpNorm<Eigen::Infinity>();
  s.free.resize(m);
  for (int i = 0; i < m; ++i) s.free[i] = s.p[i] > 0.0;
  bool found = min_norm();
  for (int i = 0; i < m && found; ++i)
    found = s.free[i] ? s.target[i] >= 0.0 : s.dual[i] <= kDualTol * p_max;
  // Else an active set from all members: those whose minimum-norm impulse is negative are
  // fixed at 0 and the rest re-solved, until the minimum-norm impulse of the free ones is
  // nonnegative.
  if (!found) s.free.assign(m, 1);
  for (int round = 0; !found && round < kMaxRounds; ++round) {
    if (!min_norm()) break;
    int negative = 0;
    for (int i = 0; i < m; ++i)
      if (s.free[i] && s.target[i] < 0.0) {
        s.free[i] = 0;
        ++negative;
      }
    if (negative == 0) {
      found = true;
      break;
    }
  }
  if (!found) return;
  // The friction rows μ p_n − Σ p_f ≥ 0 must hold at the target too (or be no worse).
  for (int i = 0; i < m; ++i) {
    const int c = s.members[i];
    double friction = 0.0;
    for (int j = 0; j < a.nd; ++j) friction += (*z)[nc + c * a.nd + j];
    if (a.mu[c] * s.target[i] < std::min(friction, a.mu[c] * s.p[i])) return;
  }
  for (int i = 0; i < m; ++i) (*z)[s.members[i]] = s.target[i];
}

}  // namespace vinci::sim::internal
