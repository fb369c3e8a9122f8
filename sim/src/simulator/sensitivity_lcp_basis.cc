#include "sensitivity_lcp_basis.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "../formulations/step_record.h"
#include "../formulations/stewart_trinkle_internal.h"
#include "../solvers/scratch_lease.h"
#include "sensitivity_linearization.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/geometry/contact_rate.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim::internal {
namespace {

// A held pair's nonzero side must exceed the activity tolerance by this factor: the general
// path's tolerance also counts the step equations' residual, which this path does not evaluate,
// so only pairs that both would classify alike are taken.
constexpr double kClearMargin = 1e3;
// The basic block's smallest LU pivot relative to its largest at least this (the general path
// factors a singular active block by the complete orthogonal decomposition: not this path's
// answer).
constexpr double kMinPivotRatio = 1e-10;
// A quaternion's central difference step in (q, h ω) along its unit direction.
constexpr double kRotationStep = 1e-6;

// A singular basic block's solution, and a sticking contact's implied slip rates, must hold to
// this relative residual (the central differences' error is far below it), the latter also
// within kDifferenceRoundoff's absolute floor.
constexpr double kConsistencyTol = 1e-7;
// An evaluation of the frozen rows along s is taken to hold each entry to this relative
// round-off (a few hundred operations of ε): an implied row's rate at or below the difference
// of two such errors over 2·step is zero as far as the differences can tell.
constexpr double kDifferenceRoundoff = 100 * std::numeric_limits<double>::epsilon();
constexpr double kPi = 3.14159265358979323846;

// The roles of the step LCP's entries z = [p_n; p_f; σ] in the derivative:
//   basic      its row held (dw_i = 0), its unknown free: a loaded normal; a sliding contact's σ
//              and loaded directions; a sticking contact's held directions (a basis of its
//              tangent space, loaded ones first);
//   nonbasic   dz_i = 0, w_i > 0 bounds the stable radius;
//   implied    dz_i = 0 and dw_i = 0 as a combination of held rows (a sticking contact's other
//              directions; an unloaded contact's normal that touches: checked per column);
//   free_sign  the held directions of a sticking contact that carry no load (their dz may be
//              negative: load along −d_j, which other directions carry in the LCP);
//   cones      a sticking contact's σ row (w_σ > 0) with its free_sign range, for the radius.
// A separated or touching unloaded contact's friction and σ entries are held at 0 unchecked:
// with p_n held at 0 the cone admits no friction, and σ moves no velocity.
struct Cone {
  int row, first, count;
};

// A list of at most `capacity` entries in storage kept across calls (push_back inlined: the
// classification fills ~80 entries a step on a resting box).
template <typename T>
class ShortList {
 public:
  void Reset(int capacity) {
    if (static_cast<int>(items_.size()) < capacity)
      items_.resize(static_cast<std::size_t>(capacity));
    n_ = 0;
  }
  void push_back(const T& item) { items_[static_cast<std::size_t>(n_++)] = item; }
  std::size_t size() const { return static_cast<std::size_t>(n_); }
  const T& operator[](int k) const { return items_[static_cast<std::size_t>(k)]; }
  const T* begin() const { return items_.data(); }
  const T* end() const { return items_.data() + n_; }

 private:
  std::vector<T> items_;
  int n_ = 0;
};

struct BasisScratch {
  MatrixXd wg;  // W G_B (nv × |B|)
  VectorXd w, v1, v1_p, v1_m, g_p, g_m, dg, dz, dv, unit, dz_b, rhs;
  VectorXd dnu, dnu_abs, u;  // dν = W G_B dz_B, its cancellation scale; row-space work
  VectorXd g_abs;            // |G_B| |dz_B| (row space)
  ShortList<int> basic, nonbasic, implied, free_sign;  // each holds at most m entries
  ShortList<Cone> cones;                               // at most nc
  int sliding = 0;                                     // contacts with σ basic
  int degenerate = 0;                                  // pairs with both sides at zero
  MatrixXd m_bb, lu, a_dense, p;
  std::vector<int> lu_rows;  // the LU's row interchanges
  Eigen::FullPivLU<MatrixXd> full_lu;
};

// Fills the roles above from z*, w* = M z* + q and the activity tolerance; false where some
// pair has no clear role (a pair between tol and kClearMargin·tol, a contact at its cone's
// edge, more loaded directions than its tangent space has dimensions, loaded friction on an
// unloaded contact, or a touching unloaded contact beside a sliding one).
bool ClassifyContacts(Dim dim, const StewartTrinkle::Assembly& a, const VectorXd& z,
                      const VectorXd& w, double tol, BasisScratch* b) {
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd, nf = nc * nd;
  const double clear = kClearMargin * tol;
  const auto basic = [&](int i) { return w[i] <= tol && z[i] > clear; };
  const auto nonbasic = [&](int i) { return z[i] <= tol && w[i] > clear; };
  const auto zero = [&](int i) { return z[i] <= tol && w[i] <= tol; };
  const auto angle = [&](int j) { return 2.0 * kPi * j / nd; };  // planar: ±t at 0, π
  const int tangent_dim = dim == Dim::kSpatial ? 2 : 1;
  const int m = nc + nf + nc;
  b->basic.Reset(m);
  b->nonbasic.Reset(m);
  b->implied.Reset(m);
  b->free_sign.Reset(m);
  b->cones.Reset(nc);
  b->sliding = b->degenerate = 0;
  int unloaded = 0;  // touching unloaded contacts
  for (int k = 0; k < nc; ++k) {
    const int n = k, f0 = nc + k * nd, s = nc + nf + k;
    if (nonbasic(n) || zero(n)) {  // separated, or touching unloaded
      // A touching unloaded contact (p_n = 0 = w_n: a redundant corner the solver left without
      // load) keeps touching only if its gap rate is a combination of the held rows: implied.
      if (zero(n)) {
        b->implied.push_back(n);
        ++b->degenerate;
        ++unloaded;
      } else {
        b->nonbasic.push_back(n);
      }
      int at_zero = 0;
      for (int i = f0; i < f0 + nd; ++i) {
        if (z[i] > tol) return false;
        at_zero += w[i] <= tol;
      }
      // Counted as the general path counts them (Linearization::HoldUnloadedFriction): with slip
      // (σ > 0) a separated contact's friction stays 0 on both sides, and a touching unloaded
      // one whose slip attains one direction's maximum slides along it if it takes load.
      const bool slipping = z[s] > tol;
      if (!(slipping && (nonbasic(n) || at_zero == 1))) b->degenerate += at_zero;
      b->degenerate += zero(s);
      continue;
    }
    if (!basic(n)) return false;
    b->basic.push_back(n);
    if (basic(s)) {  // sliding: every direction strictly complementary
      ++b->sliding;
      b->basic.push_back(s);
      for (int i = f0; i < f0 + nd; ++i) {
        if (basic(i))
          b->basic.push_back(i);
        else if (nonbasic(i))
          b->nonbasic.push_back(i);
        else
          return false;
      }
      continue;
    }
    if (!nonbasic(s) || nd < 2 * tangent_dim) return false;
    // Sticking strictly inside the cone (σ = 0 < w_σ): every slip rate w_j = d_jᵀ ν_rel is zero.
    int chosen[2], held = 0;
    for (int j = 0; j < nd; ++j) {
      if (basic(f0 + j)) {
        if (held == tangent_dim) return false;
        chosen[held++] = j;
      } else if (!zero(f0 + j)) {
        return false;
      }
    }
    const int loaded = held;
    if (held == 2 && std::abs(std::sin(angle(chosen[0]) - angle(chosen[1]))) < 0.5) return false;
    // Filled with unloaded directions: the first, then a quarter turn on (to the nearest of the
    // equally spaced directions: |sin| ≥ sin 72° for n_d ≥ 3).
    if (held == 0) chosen[held++] = 0;
    if (held < tangent_dim) chosen[held++] = (chosen[0] + (nd + 2) / 4) % nd;
    const int first = static_cast<int>(b->free_sign.size());
    for (int t = 0; t < held; ++t) {
      b->basic.push_back(f0 + chosen[t]);
      if (t >= loaded) b->free_sign.push_back(f0 + chosen[t]);
    }
    for (int j = 0; j < nd; ++j)
      if (std::find(chosen, chosen + held, j) == chosen + held) b->implied.push_back(f0 + j);
    b->degenerate += nd - loaded;
    b->cones.push_back({s, first, held - loaded});
  }
  // With a sliding contact the normal split of redundant contacts moves the velocities (each
  // contact's friction acts at its own point): an unloaded one's share is not the basis' to fix.
  return unloaded == 0 || b->sliding == 0;
}

// LU with partial (row) pivoting of a small square block in place, rows[k] the row swapped
// with k at step k; false where some pivot is at or below kMinPivotRatio times the largest.
bool SmallLuInPlace(MatrixXd* a, std::vector<int>* rows) {
  const int n = static_cast<int>(a->rows());
  rows->resize(n);
  double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) {
    int r = k;
    for (int i = k + 1; i < n; ++i)
      if (std::abs((*a)(i, k)) > std::abs((*a)(r, k))) r = i;
    (*rows)[k] = r;
    if (r != k) a->row(k).swap(a->row(r));
    const double pivot = (*a)(k, k);
    largest = std::max(largest, std::abs(pivot));
    smallest = std::min(smallest, std::abs(pivot));
    if (pivot == 0.0) return false;
    for (int i = k + 1; i < n; ++i) {
      const double l = ((*a)(i, k) /= pivot);
      for (int j = k + 1; j < n; ++j) (*a)(i, j) -= l * (*a)(k, j);
    }
  }
  return smallest > kMinPivotRatio * largest;
}

// The Cholesky factor L (P = L Lᵀ) of a small symmetric positive definite block in place, from
// and into its lower triangle; false where a pivot is not positive or L's smallest diagonal
// entry squared is at or below kMinPivotRatio times its largest squared.
bool SmallCholeskyInPlace(MatrixXd* p) {
  MatrixXd& l = *p;
  const int n = static_cast<int>(l.rows());
  double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
  for (int j = 0; j < n; ++j) {
    double d = l(j, j);
    for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
    if (!(d > 0.0)) return false;
    const double ljj = std::sqrt(d);
    l(j, j) = ljj;
    largest = std::max(largest, ljj);
    smallest = std::min(smallest, ljj);
    for (int i = j + 1; i < n; ++i) {
      double sum = l(i, j);
      for (int k = 0; k < j; ++k) sum -= l(i, k) * l(j, k);
      l(i, j) = sum / ljj;
    }
  }
  return smallest * smallest > kMinPivotRatio * largest * largest;
}

// x ← P⁻¹ x from SmallCholeskyInPlace's factor.
void SmallCholeskySolve(const MatrixXd& l, VectorXd* x) {
  const int n = static_cast<int>(l.rows());
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < i; ++k) (*x)[i] -= l(i, k) * (*x)[k];
    (*x)[i] /= l(i, i);
  }
  for (int i = n - 1; i >= 0; --i) {
    for (int k = i + 1; k < n; ++k) (*x)[i] -= l(k, i) * (*x)[k];
    (*x)[i] /= l(i, i);
  }
}

// x ← A⁻¹ x from SmallLuInPlace's factors.
void SmallLuSolve(const MatrixXd& lu, const std::vector<int>& rows, VectorXd* x) {
  const int n = static_cast<int>(lu.rows());
  for (int k = 0; k < n; ++k) std::swap((*x)[k], (*x)[rows[k]]);
  for (int i = 1; i < n; ++i)
    for (int j = 0; j < i; ++j) (*x)[i] -= lu(i, j) * (*x)[j];
  for (int i = n - 1; i >= 0; --i) {
    for (int j = i + 1; j < n; ++j) (*x)[i] -= lu(i, j) * (*x)[j];
    (*x)[i] /= lu(i, i);
  }
}

// Column e's nonzeros of G = [G_n G_f] (an impulse entry of z, e < nc + nf): fn(row, value).
template <typename Fn>
void ForImpulseColumn(const StewartTrinkle::Assembly& a, int e, Fn&& fn) {
  const int nc = static_cast<int>(a.contacts.size());
  for (SparseMatrixd::InnerIterator it(e < nc ? a.G_n : a.G_f, e < nc ? e : e - nc); it; ++it)
    fn(static_cast<int>(it.row()), it.value());
}

// W G_B into b->wg (nv × |B|, W = M⁻¹ block diagonal; a σ column zero): ν_after moves by
// W G_B dz_B. Each nonzero G(r, e) adds G(r, e) times column r of r's block of W.
void ImpulseColumnsInto(const StewartTrinkle::Assembly& a, BasisScratch* b) {
  const int nc = static_cast<int>(a.contacts.size()), nf = nc * a.nd;
  const int nb = static_cast<int>(b->basic.size()), nv = a.M_inv.rows();
  const int bs = a.M_inv.block_size();
  b->wg.setZero(nv, nb);
  for (int j = 0; j < nb; ++j) {
    const int e = b->basic[j];
    if (e >= nc + nf) continue;  // σ: no impulse
    double* col = b->wg.col(j).data();
    ForImpulseColumn(a, e, [&](int r, double v) {
      const int o = r - r % bs;
      const double* w = a.M_inv.BlockAt(o).col(r - o).data();
      for (int k = 0; k < bs; ++k) col[o + k] += v * w[k];
    });
  }
}

// M_BB, StewartTrinkle::BuildLcpInto's matrix on the rows and columns B for a step without
// joints, corners, supports or compliant pairs (excluded before): G_iᵀ (W G_B) on the impulse
// entries, E (1 at (p_f,j, σ_c)), −Eᵀ (−1 at (σ_c, p_f,j)) and U (μ_c at (σ_c, p_n,c)) by their
// pattern.
void BasisBlockInto(const StewartTrinkle::Assembly& a, BasisScratch* b) {
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd, nf = nc * nd;
  const int nb = static_cast<int>(b->basic.size());
  const auto contact_of = [&](int e) {
    return e < nc ? e : e < nc + nf ? (e - nc) / nd : e - nc - nf;
  };
  b->m_bb.setZero(nb, nb);
  for (int i = 0; i < nb; ++i) {
    const int ei = b->basic[i], ci = contact_of(ei);
    if (ei < nc + nf) {
      ForImpulseColumn(a, ei, [&](int r, double v) { b->m_bb.row(i) += v * b->wg.row(r); });
      if (ei >= nc)  // a friction row: E on its contact's σ column
        for (int j = 0; j < nb; ++j)
          if (b->basic[j] == nc + nf + ci) b->m_bb(i, j) = 1.0;
      continue;
    }
    for (int j = 0; j < nb; ++j) {  // σ_c's row: U and −Eᵀ on its contact's entries
      const int ej = b->basic[j];
      if (ej < nc + nf && contact_of(ej) == ci) b->m_bb(i, j) = ej < nc ? a.mu[ci] : -1.0;
    }
  }
}

// Row i's rate dw_i = dg_i + (M(:, B) dz_B)_i from dν = W G_B dz_B (b.dnu) and dz (b.dz):
// G_iᵀ dν on an impulse row, plus dz_σc on a friction row of contact c; μ_c dz_n,c − Σ_j dz_f,c,j
// on σ_c's row. *size: the same sum over absolute values, |dν| replaced by b.dnu_abs =
// |W G_B| |dz_B| (or its bound |W| |G_B| |dz_B|): the scale of the cancellation in the rate.
double RowRate(const StewartTrinkle::Assembly& a, const BasisScratch& b, int i, double* size) {
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd, nf = nc * nd;
  double rate = b.dg[i], abs_sum = std::abs(b.dg[i]);
  if (i < nc + nf) {
    ForImpulseColumn(a, i, [&](int r, double v) {
      rate += v * b.dnu[r];
      abs_sum += std::abs(v) * b.dnu_abs[r];
    });
    if (i >= nc) {
      const double t = b.dz[nc + nf + (i - nc) / nd];
      rate += t;
      abs_sum += std::abs(t);
    }
  } else {
    const int c = i - nc - nf;
    const double t = a.mu[c] * b.dz[c];
    rate += t;
    abs_sum += std::abs(t);
    for (int j = nc + c * nd; j < nc + (c + 1) * nd; ++j) {
      rate -= b.dz[j];
      abs_sum += std::abs(b.dz[j]);
    }
  }
  if (size) *size = abs_sum;
  return rate;
}

// Redundant sticking or resting contacts without a sliding one: M_BB = Aᵀ W A, A = G_B
// (nv × |B|, more held rows than velocities). If A has full row rank, P = A Aᵀ is positive
// definite and M_BB dz_B = r has, when consistent, the unique dν = W A dz_B = P⁻¹ A r, and the
// minimum-norm dz_B = Aᵀ P⁻¹ M dν (A dz_B = M dν). False where P is singular at round-off.
bool FactorRowSpace(const StewartTrinkle::Assembly& a, BasisScratch* b) {
  const int nb = static_cast<int>(b->basic.size()), nv = a.M_inv.rows();
  if (nb <= nv) return false;
  b->a_dense.setZero(nv, nb);
  for (int j = 0; j < nb; ++j)
    ForImpulseColumn(a, b->basic[j], [&](int r, double v) { b->a_dense(r, j) = v; });
  // P's lower triangle (a sum of the columns' outer products), then its Cholesky factor in
  // place.
  b->p.setZero(nv, nv);
  for (int j = 0; j < nb; ++j) {
    const double* col = b->a_dense.col(j).data();
    for (int c = 0; c < nv; ++c) {
      if (col[c] == 0.0) continue;
      double* pc = b->p.col(c).data();
      for (int r = c; r < nv; ++r) pc[r] += col[r] * col[c];
    }
  }
  return SmallCholeskyInPlace(&b->p);
}

bool FrictionOnly(const Scene& scene, const ParamSelection& selection) {
  for (int index : selection.indices()) {
    const ParamKind k = scene.param_table().info(index).kind;
    if (k != ParamKind::kFriction && k != ParamKind::kDefaultFriction) return false;
  }
  return true;
}

}  // namespace

bool PropagateOnLcpBasis(const Simulator& sim, const Params& params,
                         const ParamSelection& selection, const State& x, const StepInput& u,
                         const State& next, const MatrixXd& S, MatrixXd* S_next,
                         const SensitivityOptions& options, Workspace* ws, StepSensitivity* st) {
  const auto* stewart = dynamic_cast<const StewartTrinkle*>(&sim.formulation());
  if (!stewart || options.smoothing > 0.0 || !FrictionOnly(sim.scene(), selection)) return false;
  Workspace own_ws;
  Workspace* w = ws ? ws : &own_ws;
  const Scene& model = sim.ResolveWithInputs(params, u, w);
  const std::shared_ptr<const Scene>& scene = u.motions.empty() ? w->model : w->motion_model;
  // Without a state direction (the parameters' own columns, as StepDerivatives asks) nothing
  // moves the contacts: the step's own assembly serves, where this thread's last step made it.
  // A contact between two polytopes may sit at a feature switch, which only the freeze counts
  // (StepModel::feature_kinks): such a step is frozen.
  bool moves = false;
  for (int c = 0; c < S.cols() && !moves; ++c) moves = !(S.col(c).cwiseAbs().maxCoeff() == 0.0);
  const StewartTrinkle::Assembly* a0 = moves ? nullptr : StepAssembly(*stewart, scene, x, u);
  for (std::size_t k = 0; a0 && k < a0->contacts.size(); ++k) {
    const Contact& ct = a0->contacts[k];
    if (!ct.point.corner && IsPolytopeType(model.bodies[ct.body_a].shapes[ct.shape_a].type) &&
        IsPolytopeType(model.bodies[ct.body_b].shapes[ct.shape_b].type))
      a0 = nullptr;
  }
  ScratchLease<std::unique_ptr<StepModel>> frozen_lease;
  std::unique_ptr<StepModel>& frozen = frozen_lease.get();
  if (!a0) {
    FreezeInto(sim.formulation(), scene, params, x, u, &frozen);
    a0 = FrozenAssembly(*frozen);
    if (!a0 || frozen->feature_kinks() > 0) return false;
  }
  const int nc = static_cast<int>(a0->contacts.size()), nd = a0->nd, nf = nc * nd;
  if (a0->psi_b.size() > 0 || !a0->corner_contact.empty() || a0->support.points() > 0) return false;
  for (const CompliantNormalRow& law : a0->compliance)
    if (law.compliant) return false;
  const int m = nc + nf + nc;
  const VectorXd& z = next.warm_start;
  if (z.size() != m || !z.allFinite()) return false;

  ScratchLease<BasisScratch> lease;
  BasisScratch& b = lease.get();
  const int nq = static_cast<int>(x.q.size()), nx = nq + static_cast<int>(x.v.size());
  b.unit.setZero(nx);
  // w* = M z* + q and ν_after(z*) at the freeze (no M formed: most rejections come below).
  PlainLcpAtInto(*stewart, *a0, x, z, &b.w, &b.v1);
  // The freeze's LCP must give the step's own end velocity (the step may have changed z after
  // its solve, e.g. spread indeterminate normals).
  if (b.w.size() != m || b.v1.size() != next.v.size() ||
      !((b.v1 - next.v).cwiseAbs().maxCoeff() <=
        1e-9 * std::max(1.0, next.v.cwiseAbs().maxCoeff())))
    return false;
  // The general path's activity tolerance (Linearization::Compute) without its equality part.
  double scale = 0.0, violation = 0.0;
  for (int i = 0; i < m; ++i) {
    scale = std::max({scale, std::abs(z[i]), std::abs(b.w[i])});
    violation = std::max(violation, std::abs(std::min(z[i], b.w[i])));
  }
  const double tol = options.active_tol * scale + 10.0 * violation;
  if (!ClassifyContacts(model.dim, *a0, z, b.w, tol, &b)) return false;
  // How M_BB dz_B = −dg_B is solved (the block at the freeze):
  //  - with a sliding contact (σ in B) M_BB must be regular: no pivot of its partial-pivoting LU
  //    at round-off relative to the largest;
  //  - without one M_BB = G_Bᵀ W G_B is symmetric positive semidefinite and null(M_BB) =
  //    null(G_B), so every solution of a consistent system gives the same dν = W G_B dz_B (the
  //    general path's minimum-norm solution among them). A regular block (|B| ≤ nv) by the
  //    partial-pivoting LU; more held rows than velocities (redundant contacts) in G_B's row
  //    space (FactorRowSpace); else the full-pivoting LU reveals the rank. A singular block has
  //    its consistency checked per column.
  enum class Solve { kNone, kLu, kRowSpace, kFullLu } solve = Solve::kNone;
  const int nb = static_cast<int>(b.basic.size()), nv = a0->M_inv.rows();
  if (nv != nx - nq) return false;
  const auto regular_lu = [&] {
    b.lu = b.m_bb;
    return SmallLuInPlace(&b.lu, &b.lu_rows);
  };
  if (nb > 0 && b.sliding == 0 && FactorRowSpace(*a0, &b)) {
    solve = Solve::kRowSpace;  // W G_B is not formed
  } else if (nb > 0) {
    ImpulseColumnsInto(*a0, &b);
    BasisBlockInto(*a0, &b);
    if (b.sliding > 0 || nb <= nv) {
      if (regular_lu())
        solve = Solve::kLu;
      else if (b.sliding > 0)
        return false;
    }
    if (solve == Solve::kNone) {
      b.full_lu.setThreshold(kMinPivotRatio);
      b.full_lu.compute(b.m_bb);
      solve = Solve::kFullLu;
    }
  }
  const bool singular = solve == Solve::kFullLu && b.full_lu.rank() < nb;

  const int p = selection.size(), ncols = static_cast<int>(S.cols());
  const VectorXd theta = selection.Get(params);
  double xn =
      std::max(nq ? x.q.cwiseAbs().maxCoeff() : 0.0, x.v.size() ? x.v.cwiseAbs().maxCoeff() : 0.0);
  const double step = options.state_step * std::max(1.0, xn);
  const double h = stewart->options().dt;
  MatrixXd out = MatrixXd::Constant(nx, ncols, std::numeric_limits<double>::quiet_NaN());
  for (int c = 0; c < ncols; ++c) {
    const auto s = S.col(c);
    b.dg.setZero(m);
    b.dv.setZero(nx - nq);
    const double sn = s.cwiseAbs().maxCoeff();
    if (!std::isfinite(sn)) return false;
    double noise = 0.0;  // dg's round-off from the central differences
    if (sn > 0.0) {
      // Along the unit direction, scaled back (a carried column may have decayed to denormals).
      b.unit = s / sn;
      if (!PlainLcpAlongInto(*frozen, u, b.unit, step, z, &b.g_p, &b.v1_p) ||
          !PlainLcpAlongInto(*frozen, u, b.unit, -step, z, &b.g_m, &b.v1_m))
        return false;
      b.dg = (b.g_p - b.g_m) * (sn / (2 * step));
      if (m > 0)
        noise = kDifferenceRoundoff *
                std::max(b.g_p.cwiseAbs().maxCoeff(), b.g_m.cwiseAbs().maxCoeff()) * sn /
                (2 * step);
      b.dv = (b.v1_p - b.v1_m) * (sn / (2 * step));
    }
    if (c < p) {
      // ∂(M z*)/∂μ: the cone row of each contact whose μ is this parameter gains its p_n.
      const int index = selection.indices()[c];
      for (int k = 0; k < nc; ++k)
        if (a0->contacts[k].mu_param == index) b.dg[nc + nf + k] += z[k];
    }
    b.dz.setZero(m);
    b.dnu.setZero(nv);
    b.dnu_abs.setZero(nv);
    b.rhs.resize(nb);
    for (int i = 0; i < nb; ++i) b.rhs[i] = -b.dg[b.basic[i]];
    const double rhs_norm = nb > 0 ? b.rhs.cwiseAbs().maxCoeff() : 0.0;
    if (solve == Solve::kRowSpace) {
      // dν = P⁻¹ A r, consistent if Aᵀ dν = r; dz_B = Aᵀ P⁻¹ M dν.
      b.dnu.noalias() = b.a_dense * b.rhs;
      SmallCholeskySolve(b.p, &b.dnu);
      b.dz_b.noalias() = b.a_dense.transpose() * b.dnu;
      if (!((b.dz_b - b.rhs).cwiseAbs().maxCoeff() <= kConsistencyTol * rhs_norm)) return false;
      a0->M.Multiply(b.dnu, &b.u);
      SmallCholeskySolve(b.p, &b.u);
      b.dz_b.noalias() = b.a_dense.transpose() * b.u;
      for (int i = 0; i < nb; ++i) b.dz[b.basic[i]] = b.dz_b[i];
    } else if (solve != Solve::kNone) {
      if (solve == Solve::kLu) {
        b.dz_b = b.rhs;
        SmallLuSolve(b.lu, b.lu_rows, &b.dz_b);
      } else {
        b.dz_b = b.full_lu.solve(b.rhs);
      }
      if (singular &&
          !((b.m_bb * b.dz_b - b.rhs).cwiseAbs().maxCoeff() <= kConsistencyTol * rhs_norm))
        return false;  // inconsistent along this column: a mode change the basis cannot follow
      for (int i = 0; i < nb; ++i) b.dz[b.basic[i]] = b.dz_b[i];
      b.dnu.noalias() = b.wg * b.dz_b;
    }
    // The scale of the cancellation in dν: |W G_B| |dz_B|, in the row space its bound
    // |W| |G_B| |dz_B| (W G_B not formed; equal where W's blocks are diagonal).
    if (solve == Solve::kRowSpace) {
      b.g_abs.setZero(nv);
      for (int j = 0; j < nb; ++j) {
        const double d = std::abs(b.dz_b[j]);
        ForImpulseColumn(*a0, b.basic[j], [&](int r, double v) { b.g_abs[r] += std::abs(v) * d; });
      }
      const int bs = a0->M_inv.block_size();
      for (int o = 0; o < nv; o += bs) {
        const auto block = a0->M_inv.BlockAt(o);
        for (int k = 0; k < bs; ++k)
          for (int i = 0; i < bs; ++i) b.dnu_abs[o + i] += std::abs(block(i, k)) * b.g_abs[o + k];
      }
    } else if (nb > 0) {
      for (int j = 0; j < nb; ++j) {
        const double d = std::abs(b.dz_b[j]);
        const double* col = b.wg.col(j).data();
        for (int i = 0; i < nv; ++i) b.dnu_abs[i] += std::abs(col[i]) * d;
      }
    }
    // A sticking contact's other friction rows are combinations of its held ones (σ held at 0),
    // a touching unloaded contact's normal row of the others': their rates must stay zero, so
    // that both sides of the column hold them.
    const double dg_norm = m > 0 ? b.dg.cwiseAbs().maxCoeff() : 0.0;
    for (int i : b.implied) {
      double size = 0.0;
      const double rate = RowRate(*a0, b, i, &size);
      if (!(std::abs(rate) <= kConsistencyTol * size + 1e-12 * dg_norm + noise)) return false;
    }
    // The stable radius of Linearization::StableRadius on this basis.
    double rho = std::numeric_limits<double>::infinity();
    for (int i : b.basic)
      if (b.dz[i] < 0.0 && z[i] > tol) rho = std::min(rho, z[i] / -b.dz[i]);
    for (int i : b.nonbasic) {
      const double rate = RowRate(*a0, b, i, nullptr);
      if (rate < 0.0 && b.w[i] > tol) rho = std::min(rho, b.w[i] / -rate);
    }
    // A sticking contact's cone slack w_σ = μ p_n − Σ p_f: an unloaded held direction's impulse
    // may turn negative, i.e. point along −d_j, which the cone's gauge counts at most twice
    // (1/cos(π/n_d) ≤ 2 for n_d ≥ 3; planar −d_j is a direction): its rate is bounded below by
    // the linear one less 3 |dz_j| (the linear rate counts −dz_j).
    for (const auto& [row, first, count] : b.cones) {
      double rate = RowRate(*a0, b, row, nullptr);
      for (int j = first; j < first + count; ++j) rate -= 3.0 * std::abs(b.dz[b.free_sign[j]]);
      if (rate < 0.0) rho = std::min(rho, b.w[row] / -rate);
    }
    const double column_scale = c < p ? std::abs(theta[c]) : 1.0;
    if (!(rho >= kMinStableRadius * std::max(1.0, column_scale))) return false;
    // dν_ℓ+1 = (ν_after's x part) + W G dz (VelocityAfterWith without joints or supports).
    b.dv += b.dnu;
    out.col(c).tail(nx - nq) = b.dv;
    // dq_ℓ+1 per dynamic body: positions q + h ν exactly, a quaternion by central differences.
    for (int bi : model.dynamic_bodies()) {
      const BodyIndex& idx = model.index(bi);
      for (int k = 0; k < 3; ++k) out(idx.q + k, c) = s[idx.q + k] + h * b.dv[idx.v + k];
      if (model.dim != Dim::kSpatial) continue;
      // Int(Q, φ) = Q ⊗ Exp(φ), φ = h ω: along (dQ, h dω) / n, n its ∞-norm.
      double d[7] = {0, 0, 0}, n = 0.0;
      for (int k = 3; k < 7; ++k) n = std::max(n, std::abs(d[k] = s[idx.q + k]));
      double phi[6] = {0, 0, 0}, dphi[3];
      for (int k = 0; k < 3; ++k) {
        phi[3 + k] = h * next.v[idx.v + 3 + k];
        dphi[k] = h * b.dv[idx.v + 3 + k];
        n = std::max(n, std::abs(dphi[k]));
      }
      if (!(n > 0.0)) {
        for (int k = 3; k < 7; ++k) out(idx.q + k, c) = 0.0;
        continue;
      }
      double qp[7], qm[7], vp[6], vm[6], rp[7], rm[7];
      for (int k = 0; k < 7; ++k) {
        qp[k] = x.q[idx.q + k] + kRotationStep * d[k] / n;
        qm[k] = x.q[idx.q + k] - kRotationStep * d[k] / n;
      }
      for (int k = 0; k < 6; ++k) vp[k] = vm[k] = phi[k];
      for (int k = 0; k < 3; ++k) {
        vp[3 + k] += kRotationStep * dphi[k] / n;
        vm[3 + k] -= kRotationStep * dphi[k] / n;
      }
      IntegratePosition(Dim::kSpatial, qp, vp, 1.0, rp);
      IntegratePosition(Dim::kSpatial, qm, vm, 1.0, rm);
      for (int k = 3; k < 7; ++k) out(idx.q + k, c) = (rp[k] - rm[k]) * (n / (2 * kRotationStep));
    }
    if (!out.col(c).allFinite()) return false;
  }
  // A mode change within the step: the contact set found at the end differs (as the general
  // path).
  const StepLayout l = StewartTrinkle::LayoutOf(model, *a0);  // before Layout may step
  const StepLayout end = sim.formulation().Layout(model, next);
  const bool changed = end.nc != l.nc || end.nk != l.nk || end.ns != l.ns;
  *S_next = std::move(out);
  *st = StepSensitivity();
  st->contact_set_changed = changed;
  st->on_lcp_basis = true;
  st->degenerate_pairs = b.degenerate;
  st->status = changed            ? SensitivityStatus::kModeChange
               : b.degenerate > 0 ? SensitivityStatus::kDegenerate
                                  : SensitivityStatus::kExact;
  if (b.degenerate > 0)
    st->message = std::to_string(b.degenerate) +
                  " degenerate pair(s) (sticking contacts' unloaded friction directions, their "
                  "slip rates zero on both sides; unloaded contacts' pairs)";
  if (changed) st->message += std::string(st->message.empty() ? "" : "; ") + "contact set changed";
  return true;
}

}  // namespace vinci::sim::internal
