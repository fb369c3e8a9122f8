#include "vinci/sim/formulations/stewart_trinkle.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "contact_columns.h"
#include "dense_solve.h"
#include "end_detection.h"
#include "sparse_lcp.h"
#include "spread_normals.h"
#include "step_util.h"
#include "stewart_trinkle_internal.h"
#include "vinci/sim/formulations/joint.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/sparse_lemke.h"

namespace vinci::sim {

namespace internal {

BodyKinematics PrescribedKinematics(const Scene& model, int body, double t, double h) {
  const Body& b = model.bodies[body];
  return EvaluateMotion(b.motion, b.X_WB0, model.dim == Dim::kPlanar, t, h);
}

void CheckShapesSupported(const Scene& model) {
  for (const Body& b : model.bodies)
    for (const Shape& s : b.shapes)
      if (RequiresImplicitContact(s.type))
        throw std::invalid_argument("body '" + b.name + "' shape '" + s.name + "': shape type " +
                                    ShapeKeyword(s.type) +
                                    " requires formulation: gi (the Stewart-Trinkle and "
                                    "Anitescu-Potra steppers have no contact for it)");
}

}  // namespace internal

namespace {

using internal::CheckShapesSupported;
using internal::PrescribedKinematics;
using namespace internal::contact_columns;  // NOLINT(build/namespaces): this file's own writers

constexpr double kPi = 3.14159265358979323846;
// Plain-contact LCPs with at least this many unknowns that the warm basis does not solve are
// solved by SolveSparseLemke instead of the dense LemkeSolver (a 6432-unknown pile of 100 boxes:
// ~18 ms a step against > 2 s), with no dense fallback: a failed sparse run fails the step.
// Below it the dense solver's pivots are cheaper (bench/README.md).
constexpr int kSparseStepMinSize = 1024;
// Relative tolerance under which the two predicted gaps of a corner contact tie.
constexpr double kCornerTieTol = 1e-9;

// Tangent directions d_j, j = 0..nd−1, equally spaced in the plane ⟂ n (planar: ±t).
void FrictionDirections(Dim dim, const Vector3d& n, int nd, std::vector<Vector3d>* d) {
  d->clear();
  if (dim == Dim::kPlanar) {
    const Vector3d t(-n.y(), n.x(), 0.0);
    d->push_back(t);
    d->push_back(-t);
    return;
  }
  // (cos φ_j, sin φ_j), φ_j = 2π j / nd, computed once per thread and nd.
  thread_local int table_nd = -1;
  thread_local std::vector<std::pair<double, double>> table;
  if (table_nd != nd) {
    table.resize(static_cast<std::size_t>(nd));
    for (int j = 0; j < nd; ++j) {
      const double phi = 2.0 * kPi * j / nd;
      table[static_cast<std::size_t>(j)] = {std::cos(phi), std::sin(phi)};
    }
    table_nd = nd;
  }
  // A deterministic orthonormal tangent basis (t1, t2) for n.
  const Vector3d a = std::abs(n.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  const Vector3d t1 = n.cross(a).normalized();
  const Vector3d t2 = n.cross(t1);
  d->resize(static_cast<std::size_t>(nd));
  for (int j = 0; j < nd; ++j) {
    const auto& [c, s] = table[static_cast<std::size_t>(j)];
    (*d)[static_cast<std::size_t>(j)] = c * t1 + s * t2;
  }
}

// v->setZero(n)'s result (n entries +0, storage kept), without Eigen's out-of-line fill.
void ZeroResize(VectorXd* v, Eigen::Index n) {
  if (v->size() != n) v->resize(n);
  if (n > 0) std::memset(v->data(), 0, sizeof(double) * static_cast<std::size_t>(n));
}

// a and b have the same bits (FrictionDirections is then the same).
bool SameBits(const Vector3d& a, const Vector3d& b) {
  std::uint64_t ua[3], ub[3];
  std::memcpy(ua, a.data(), sizeof(ua));
  std::memcpy(ub, b.data(), sizeof(ub));
  return ((ua[0] ^ ub[0]) | (ua[1] ^ ub[1]) | (ua[2] ^ ub[2])) == 0;
}

// A constraint Jacobian (nv × cols) built column by column. A column touches at most two
// dynamic bodies, so it is held as at most two blocks of nvb rows (a body's ν block) and written
// into the compressed SparseMatrix at the end, blocks in row order: the entries (explicit zeros
// included) and values of a matrix built by coeffRef with two body blocks reserved per column,
// without Eigen's per-column reserve, insertion and compression — allocation-free once sized.
class JacobianColumns {
 public:
  void Start(int cols) {
    columns_.resize(static_cast<std::size_t>(cols));
    for (Column& c : columns_) c.n = 0;
  }
  // Row block of column `col` at ν offset `o` (zero on first use).
  double* Block(int col, int o) {
    Column& c = columns_[static_cast<std::size_t>(col)];
    for (int b = 0; b < c.n; ++b)
      if (c.offset[b] == o) return c.value[b];
    if (c.n == 2) throw std::logic_error("StewartTrinkle: a Jacobian column touches three bodies");
    c.offset[c.n] = o;
    std::fill(c.value[c.n], c.value[c.n] + 6, 0.0);
    return c.value[c.n++];
  }
  // Writes the columns into *G (nv × cols, compressed), reusing its storage.
  void Finish(int nv, int nvb, SparseMatrixd* G) const {
    const int cols = static_cast<int>(columns_.size());
    // Eigen's resize reallocates the outer index when there are no columns: skip it when the
    // shape is already right.
    if (G->rows() != nv || G->cols() != cols || !G->isCompressed()) G->resize(nv, cols);
    Eigen::Index nnz = 0;
    for (const Column& c : columns_) nnz += c.n * nvb;
    G->resizeNonZeros(nnz);
    int* outer = G->outerIndexPtr();
    int* inner = G->innerIndexPtr();
    double* value = G->valuePtr();
    int k = 0;
    for (int j = 0; j < cols; ++j) {
      const Column& c = columns_[static_cast<std::size_t>(j)];
      outer[j] = k;
      const bool swap = c.n == 2 && c.offset[1] < c.offset[0];
      for (int bb = 0; bb < c.n; ++bb) {
        const int b = swap ? 1 - bb : bb;
        for (int i = 0; i < nvb; ++i, ++k) {
          inner[k] = c.offset[b] + i;
          value[k] = c.value[b][i];
        }
      }
    }
    outer[cols] = k;
  }

 private:
  struct Column {
    int n = 0;
    int offset[2] = {0, 0};
    double value[2][6];
  };
  std::vector<Column> columns_;
};

// Adds `row` (the body's point-velocity row) into column `col` of G at the body's ν block,
// or, for a non-dynamic body, adds its contribution row·ν_body to *dpsi.
void Scatter(const Scene& model, int body, const BodyKinematics& k, const Vector3d& p,
             const Vector3d& d, double sign, JacobianColumns* G, int col, double* dpsi) {
  if (model.bodies[body].kind == BodyKind::kDynamic) {
    const int nvb = VelocitySize(model.dim), o = model.index(body).v;
    const auto row = PointVelocityRow(model.dim, k.X_WB, p, d);
    double* block = G->Block(col, o);
    for (int i = 0; i < nvb; ++i) block[i] += sign * row[i];
  } else {
    *dpsi += sign * d.dot(PointVelocity(k, p));
  }
}

// *G sized nv × cols, compressed, with nnz entries, its storage reused (as JacobianColumns::Finish
// sizes it).
void ResizeCompressed(int nv, int cols, Eigen::Index nnz, SparseMatrixd* G) {
  if (G->rows() != nv || G->cols() != cols || !G->isCompressed()) G->resize(nv, cols);
  G->resizeNonZeros(nnz);
}

// The same contribution to the predicted gap rate: sign·row·ν_body (dynamic body, ν = v) into
// *gv, or into *dpsi for a non-dynamic body.
void ScatterDot(const Scene& model, int body, const BodyKinematics& k, const Vector3d& p,
                const Vector3d& d, double sign, const VectorXd& v, double* gv, double* dpsi) {
  if (model.bodies[body].kind == BodyKind::kDynamic) {
    const int nvb = VelocitySize(model.dim), o = model.index(body).v;
    *gv += sign * PointVelocityRow(model.dim, k.X_WB, p, d).dot(v.segment(o, nvb));
  } else {
    *dpsi += sign * d.dot(PointVelocity(k, p));
  }
}

// The assembly's transient buffers, kept per thread between calls (allocation reuse only: every
// call overwrites what it uses, so no result depends on a previous call or on the thread).
struct AssemblyScratch {
  std::vector<BodyKinematics> kin;
  // FrictionDirections(dirs_dim, dirs_n, dirs_nd) and its pairs (PackDirectionPairs, N = 6),
  // if dirs_nd > 0: a function of those three only, so reused while they stay the same.
  std::vector<Vector3d> dirs;
  std::vector<double> dir_pairs;
  Dim dirs_dim = Dim::kSpatial;
  Vector3d dirs_n = Vector3d::Zero();
  int dirs_nd = 0;
  JacobianColumns G_b, G_1;
  JointRows joint_rows;
  VectorXd zero_v;
};

AssemblyScratch& ThreadAssemblyScratch() {
  thread_local AssemblyScratch scratch;
  return scratch;
}

// Kinematics of a non-dynamic body for ∂ψ/∂t: the pose at t and
//  - kSecant: the *secant* velocity over the step, v = (o(t+h) − o(t))/h,
//    ω = log(R(t+h) R(t)ᵀ)/h. With it the linearized end-of-step gap ψ + h(Gᵀν + ∂ψ/∂t) moves
//    exactly with a translating prescribed body (a moving floor is followed without lag); the
//    instantaneous velocity would lag by O(h²) per step.
//  - kExact: the prescription's exact velocity at t + h (the vibrating-plate studies: the
//    plate's velocity is known exactly; with an integrated plate pose the two rules coincide).
BodyKinematics StepKinematics(const Scene& model, int body, const BodyKinematics& at_t, double t,
                              double h, PrescribedVelocity rule) {
  const Body& b = model.bodies[body];
  if (b.kind != BodyKind::kPrescribed) return at_t;
  const BodyKinematics next = PrescribedKinematics(model, body, t + h, h);
  BodyKinematics k = at_t;
  if (rule == PrescribedVelocity::kExact) {
    k.v_WB = next.v_WB;
    k.w_WB = next.w_WB;
    return k;
  }
  k.v_WB = (next.X_WB.translation() - at_t.X_WB.translation()) / h;
  const Eigen::AngleAxisd dR(next.X_WB.linear() * at_t.X_WB.linear().transpose());
  k.w_WB = dR.axis() * (dR.angle() / h);
  return k;
}

}  // namespace

StewartTrinkle::StewartTrinkle(StepperOptions options, std::shared_ptr<const LcpSolver> solver)
    : options_(std::move(options)),
      solver_(std::move(solver)),
      velocity_level_(options_.formulation == FormulationType::kAnitescuPotra),
      first_order_(options_.formulation == FormulationType::kFirstOrder),
      lemke_(dynamic_cast<const LemkeSolver*>(solver_.get())) {
  if (!solver_) throw std::invalid_argument("StewartTrinkle: null solver");
}

std::string_view StewartTrinkle::name() const {
  if (first_order_) return "first-order";
  return velocity_level_ ? "anitescu-potra" : "stewart-trinkle";
}

StewartTrinkle::Assembly StewartTrinkle::Assemble(const Scene& model, const State& x,
                                                  const StepInput& u) const {
  Assembly a;
  AssembleInto(model, x, u, &a);
  return a;
}

void StewartTrinkle::AssembleInto(const Scene& model, const State& x, const StepInput& u,
                                  Assembly* a) const {
  CheckShapesSupported(model);
  // Fill() recomputes the kinematics into the same buffer.
  // Kinematics with the integrated prescribed poses, and contacts: the previous step's end
  // detection if it was made at exactly this x (end_detection.h), else found here.
  internal::DetectAtStart(model, x, options_.dt, options_.envelope, &ThreadAssemblyScratch().kin,
                          &a->contacts);
  Fill(model, x, u, /*select_corner_edges=*/true, a, /*kinematics_ready=*/true);
}

StewartTrinkle::Assembly StewartTrinkle::AssembleAt(const Scene& model, const State& x,
                                                    const StepInput& u,
                                                    std::vector<Contact> contacts,
                                                    bool select_corner_edges) const {
  Assembly a;
  a.contacts = std::move(contacts);
  Fill(model, x, u, select_corner_edges, &a);
  return a;
}

void StewartTrinkle::AssembleAtInto(const Scene& model, const State& x, const StepInput& u,
                                    bool select_corner_edges, Assembly* a) const {
  Fill(model, x, u, select_corner_edges, a);
}

void StewartTrinkle::Fill(const Scene& model, const State& x, const StepInput& u,
                          bool select_corner_edges, Assembly* assembly,
                          bool kinematics_ready) const {
  Assembly& a = *assembly;
  AssemblyScratch& scratch = ThreadAssemblyScratch();
  const Dim dim = model.dim;
  const double h = options_.dt;
  const int nv = model.num_velocities();
  const int nvb = VelocitySize(dim);
  std::vector<BodyKinematics>& kin = scratch.kin;
  if (!kinematics_ready) {  // (else AssembleInto checked the shapes)
    CheckShapesSupported(model);
    ComputeBodyKinematics(model, x, &kin);
    for (std::size_t i = 0; i < kin.size(); ++i)  // integrated prescribed poses
      if (model.bodies[i].kind == BodyKind::kPrescribed &&
          model.bodies[i].motion.pose == PoseRule::kIntegrated)
        kin[i] = PrescribedKinematics(model, static_cast<int>(i), x.t, h);
  }
  // From here on, non-dynamic bodies carry their velocity over the step (StepKinematics).
  for (std::size_t i = 0; i < kin.size(); ++i)  // (StepKinematics keeps the others' as they are)
    if (model.bodies[i].kind == BodyKind::kPrescribed)
      kin[i] =
          StepKinematics(model, static_cast<int>(i), kin[i], x.t, h, options_.prescribed_velocity);
  const int nc = static_cast<int>(a.contacts.size());
  a.nd = dim == Dim::kPlanar ? 2 : options_.friction_directions;
  const int nd = a.nd;

  // Mass matrix (block diagonal, one block per dynamic body) and external impulses.
  a.M.Resize(nv, nvb);
  a.M_inv.Resize(nv, nvb);
  ZeroResize(&a.p_ext, nv);
  for (int bi : model.dynamic_bodies()) {
    const Body& b = model.bodies[bi];
    const int o = model.index(bi).v;
    const Vector3d f =
        b.applied_force_W + (b.gravity ? Vector3d(b.mass * model.gravity_W) : Vector3d::Zero());
    if (dim == Dim::kPlanar) {
      a.M.BlockAt(o).diagonal() = Vector3d(b.mass, b.mass, b.inertia(2, 2));
      a.M_inv.BlockAt(o).diagonal() = Vector3d(1.0 / b.mass, 1.0 / b.mass, 1.0 / b.inertia(2, 2));
      a.p_ext.segment<3>(o) = h * Vector3d(f.x(), f.y(), b.applied_torque_W.z());
    } else {
      a.M.BlockAt(o).topLeftCorner<3, 3>() = b.mass * Matrix3d::Identity();
      a.M.BlockAt(o).bottomRightCorner<3, 3>() = b.inertia;
      a.M_inv.BlockAt(o).topLeftCorner<3, 3>() = Matrix3d::Identity() / b.mass;
      a.M_inv.BlockAt(o).bottomRightCorner<3, 3>() = b.inertia.inverse();
      const Matrix3d& R = kin[bi].X_WB.linear();
      const Vector3d w_B = x.v.segment<3>(o + 3);
      a.p_ext.segment<3>(o) = h * f;
      a.p_ext.segment<3>(o + 3) =
          h * (R.transpose() * b.applied_torque_W - w_B.cross(b.inertia * w_B));
    }
  }
  if (u.generalized_force.size() == nv) a.p_ext += h * u.generalized_force;
  if (first_order_) {
    // First-order model (first_order.h): h C ν_ℓ+1 = G_n p_n + G_f p_f + G_b p_b + h F_ext, i.e.
    // M → h C, no ν_ℓ term (Step and Evaluate pass ν_ℓ = 0) and no gyroscopic impulse.
    for (int bi : model.dynamic_bodies()) {
      const Body& b = model.bodies[bi];
      const int o = model.index(bi).v;
      a.M.BlockAt(o) = h * b.damping;
      // (h C)⁻¹ as inverse() forms it, in this thread's storage (dense_solve.h).
      thread_local MatrixXd hC;
      thread_local Eigen::PartialPivLU<MatrixXd> lu;
      hC = h * b.damping;
      internal::LuInverseInto(hC, &lu, a.M_inv.BlockAt(o));
      if (dim == Dim::kSpatial) {
        const Vector3d w_B = x.v.segment<3>(o + 3);
        a.p_ext.segment<3>(o + 3) += h * w_B.cross(b.inertia * w_B);
      }
    }
  }

  // Corner contacts: edge 2 (the contact's `point`) is the edge with the larger predicted gap
  // ψ_i + h (G_iᵀ ν_ℓ + ∂ψ_i/∂t) (first order: ψ_i + h ∂ψ_i/∂t); near-ties (a vertex arriving
  // exactly at the corner) go to the edge with the smaller |ψ_i|, the edge it slides along.
  a.corner_contact.clear();
  {
    // First order: ν_ℓ → 0.
    const VectorXd& v_pred = first_order_ ? scratch.zero_v.setZero(nv) : x.v;
    for (int c = 0; c < nc; ++c) {
      ContactPoint& p = a.contacts[c].point;
      if (!p.corner) continue;
      const Contact& ct = a.contacts[c];
      double gv[2] = {0.0, 0.0}, dpsi[2] = {0.0, 0.0};
      const BodyKinematics &ka = kin[ct.body_a], &kb = kin[ct.body_b];
      ScatterDot(model, ct.body_a, ka, p.p_A_W, p.n_W, 1.0, v_pred, &gv[0], &dpsi[0]);
      ScatterDot(model, ct.body_b, kb, p.p_B_W, p.n_W, -1.0, v_pred, &gv[0], &dpsi[0]);
      ScatterDot(model, ct.body_a, ka, p.p2_A_W, p.n2_W, 1.0, v_pred, &gv[1], &dpsi[1]);
      ScatterDot(model, ct.body_b, kb, p.p2_B_W, p.n2_W, -1.0, v_pred, &gv[1], &dpsi[1]);
      const double pred1 = p.gap + h * (gv[0] + dpsi[0]);
      const double pred2 = p.gap2 + h * (gv[1] + dpsi[1]);
      const double tie = kCornerTieTol * (std::abs(p.gap) + std::abs(p.gap2) +
                                          h * (std::abs(pred1 - p.gap) + std::abs(pred2 - p.gap2)));
      const bool second =
          select_corner_edges &&
          (std::abs(pred2 - pred1) <= tie ? std::abs(p.gap2) < std::abs(p.gap) : pred2 > pred1);
      if (second) {
        std::swap(p.p_A_W, p.p2_A_W);
        std::swap(p.p_B_W, p.p2_B_W);
        std::swap(p.n_W, p.n2_W);
        std::swap(p.gap, p.gap2);
      }
      a.corner_contact.push_back(c);
    }
    const int nk = static_cast<int>(a.corner_contact.size());
    scratch.G_1.Start(nk);
    a.psi_1.resize(nk);
    ZeroResize(&a.dpsi_1, nk);
    for (int k = 0; k < nk; ++k) {
      const Contact& ct = a.contacts[a.corner_contact[k]];
      const ContactPoint& p = ct.point;
      a.psi_1[k] = p.gap2;
      Scatter(model, ct.body_a, kin[ct.body_a], p.p2_A_W, p.n2_W, 1.0, &scratch.G_1, k,
              &a.dpsi_1[k]);
      Scatter(model, ct.body_b, kin[ct.body_b], p.p2_B_W, p.n2_W, -1.0, &scratch.G_1, k,
              &a.dpsi_1[k]);
    }
  }

  // Contacts. G_n and G_f are written straight into their compressed storage: a column holds
  // the block of each dynamic side, in ν order (as JacobianColumns::Finish orders them).
  // Sized for two blocks per column, then cut to the entries written (storage kept).
  const Eigen::Index nnz_max = Eigen::Index{2} * nvb * nc;
  ResizeCompressed(nv, nc, nnz_max, &a.G_n);
  ResizeCompressed(nv, nc * nd, nnz_max * nd, &a.G_f);
  int k_n = 0, k_f = 0;  // entries written
  a.psi_n.resize(nc);
  ZeroResize(&a.dpsi_n, nc);
  ZeroResize(&a.dpsi_f, nc * nd);
  a.mu.resize(nc);
  a.compliance.resize(nc);
  std::vector<Vector3d>& dirs = scratch.dirs;
  for (int c = 0; c < nc; ++c) {
    const Contact& ct = a.contacts[c];
    const ContactPoint& p = ct.point;
    a.psi_n[c] = p.gap;
    a.mu[c] = ct.mu;
    const ContactCompliance& compliance_a = model.bodies[ct.body_a].compliance;
    const ContactCompliance& compliance_b = model.bodies[ct.body_b].compliance;
    // A rigid pair's row is the default one (LinearizeNormalLaw's, which throws for h ≤ 0).
    if (compliance_a.rigid() && compliance_b.rigid() && h > 0.0)
      a.compliance[c] = CompliantNormalRow{};
    else
      a.compliance[c] = LinearizeNormalLaw(CombineCompliance(compliance_a, compliance_b), p.gap, h);
    const BodyKinematics &ka = kin[ct.body_a], &kb = kin[ct.body_b];
    ContactSide side_a = MakeContactSide(model, ct.body_a);
    ContactSide side_b = MakeContactSide(model, ct.body_b);
    if (p.n_W.allFinite()) {
      side_a.zero_term = side_b.dynamic && model.bodies[ct.body_a].kind == BodyKind::kStatic &&
                         (p.p_A_W - ka.X_WB.translation()).allFinite();
      side_b.zero_term = side_a.dynamic && model.bodies[ct.body_b].kind == BodyKind::kStatic &&
                         (p.p_B_W - kb.X_WB.translation()).allFinite();
    }
    if (!side_a.dynamic && !side_a.zero_term) side_a.v_p = PointVelocity(ka, p.p_A_W);
    if (!side_b.dynamic && !side_b.zero_term) side_b.v_p = PointVelocity(kb, p.p_B_W);
    // The dynamic sides in ν order (a contact of a body with itself: one merged block).
    DynamicSide sides[2];
    int ns = 0;
    if (side_a.dynamic)
      sides[ns++] = MakeDynamicSide(&ka, p.p_A_W - ka.X_WB.translation(), 1.0, side_a.o);
    if (side_b.dynamic)
      sides[ns++] = MakeDynamicSide(&kb, p.p_B_W - kb.X_WB.translation(), -1.0, side_b.o);
    const bool merged = ns == 2 && sides[0].o == sides[1].o;
    if (ns == 2 && sides[1].o < sides[0].o) std::swap(sides[0], sides[1]);
    const ContactColumns cc{sides,
                            merged ? 1 : ns,
                            merged,
                            &side_a,
                            &side_b,
                            !side_a.dynamic && !side_a.zero_term,
                            !side_b.dynamic && !side_b.zero_term};
    // Contacts with the normal bits of the last directions formed (a face resting on a face, a
    // resting body over steps) share them.
    if (scratch.dirs_nd != nd || scratch.dirs_dim != dim || !SameBits(p.n_W, scratch.dirs_n)) {
      FrictionDirections(dim, p.n_W, nd, &dirs);
      PackDirectionPairs(dirs, &scratch.dir_pairs);
      scratch.dirs_dim = dim;
      scratch.dirs_n = p.n_W;
      scratch.dirs_nd = nd;
    }
    if (nvb == 6) {
      WriteContactColumns<6>(cc, p.n_W, dirs, scratch.dir_pairs, c, nd, &a, &k_n, &k_f);
    } else {
      WriteContactColumns<3>(cc, p.n_W, dirs, scratch.dir_pairs, c, nd, &a, &k_n, &k_f);
    }
  }
  a.G_n.outerIndexPtr()[nc] = k_n;
  a.G_f.outerIndexPtr()[nc * nd] = k_f;
  a.G_n.resizeNonZeros(k_n);
  a.G_f.resizeNonZeros(k_f);

  // Joints.
  int nb = 0;
  for (const Joint& j : model.joints) nb += JointRowCount(j.type, dim);
  scratch.G_b.Start(nb);
  a.psi_b.resize(nb);
  ZeroResize(&a.dpsi_b, nb);
  JointRows& rows = scratch.joint_rows;
  const BodyKinematics world;
  int r = 0;
  for (const Joint& j : model.joints) {
    const BodyKinematics& ka = kin[j.body_a];
    const BodyKinematics& kb = j.body_b < 0 ? world : kin[j.body_b];
    EvaluateJoint(j, dim, ka, kb, &rows);
    const int m = static_cast<int>(rows.psi.size());
    a.psi_b.segment(r, m) = rows.psi;
    const auto add = [&](int body, const BodyKinematics& k, const MatrixXd& J) {
      if (body < 0) return;  // the world does not move
      if (model.bodies[body].kind == BodyKind::kDynamic) {
        const int o = model.index(body).v;
        for (int i = 0; i < m; ++i) {
          double* block = scratch.G_b.Block(r + i, o);
          for (int e = 0; e < nvb; ++e) block[e] += J(i, e);
        }
      } else {
        a.dpsi_b.segment(r, m) += J * BodyVelocity(dim, k);
      }
    };
    add(j.body_a, ka, rows.J_a);
    add(j.body_b, kb, rows.J_b);
    r += m;
  }

  scratch.G_1.Finish(nv, nvb, &a.G_1);
  scratch.G_b.Finish(nv, nvb, &a.G_b);

  // 2.5D support friction (support.h): empty without support points.
  AssembleSupportInto(model, x, h, /*quadratic=*/false, &a.support);
}

void StewartTrinkle::Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws,
                          State* next, StepInfo* info) const {
  internal::BeginStep(x, next, info);
  const double h = options_.dt;
  // The step's buffers (assembly, vectors, warm-basis scratch) are this thread's, reused: a
  // step whose contact structure did not change allocates nothing on the warm-basis path.
  internal::StepScratchLease lease;
  internal::StepScratch& s = lease.get();
  Assembly& a = s.assembly;
  // Kept for the step derivative's frozen model, with what it was made from (step_record.h).
  s.record.Clear();
  AssembleInto(model, x, u, &a);
  s.record.Stamp(*this, model, x, u);
  const int nc = static_cast<int>(a.contacts.size());
  info->contacts = nc;
  info->joint_rows = static_cast<int>(a.psi_b.size());
  // A corner contact's gap is max(ψ_1, ψ_2).
  VectorXd& gaps = s.gaps;
  gaps = a.psi_n;
  for (std::size_t k = 0; k < a.corner_contact.size(); ++k)
    gaps[a.corner_contact[k]] = std::max(gaps[a.corner_contact[k]], a.psi_1[k]);
  info->min_gap = nc > 0 ? gaps.minCoeff() : 0.0;
  if (!internal::CheckStartPenetration(nc, options_.max_penetration, info)) return;

  VectorXd& v_star = s.v_star;
  // Read only where the assembly has joint rows, which BuildLcpInto then overwrites.
  JointElimination& joints = s.joints;
  // First order: no ν_ℓ.
  const VectorXd& v_l = first_order_ ? s.v_l.setZero(x.v.size()) : x.v;
  VectorXd& z = s.z;
  // Warm-started Lemke on plain contacts: first the guessed basis on the structured LCP operator
  // (sparse_lcp.h, warm_basis.h); the dense LCP is built only if that basis is refused
  // (LemkeSolver then repeats the test and pivots).
  bool solved = false;
  const LemkeSolver* lemke = lemke_;
  const int m_plain = nc * (a.nd + 2);
  const bool warm_plain = x.warm_start.size() == m_plain;
  if (lemke != nullptr && nc > 0 && (warm_plain || m_plain >= kSparseStepMinSize)) {
    if (s.lcp.Build(model, a, v_l, h, velocity_level_)) {
      if (warm_plain && SolveOnWarmBasis(s.lcp, s.lcp.q(), x.warm_start, lemke->options(),
                                         &s.BasisFor(x.warm_start), &z, &info->solver)) {
        solved = true;
      } else if (m_plain >= kSparseStepMinSize) {
        // Large LCPs pivot on the sparse matrix (a dense m × m one is O(m²) memory and a
        // pivot O(m²) work). If that run fails, the step fails with its report: the dense
        // LemkeSolver's cold run, unscaled run and three regularized retries on m ≥ 1024
        // unknowns took minutes a step on the 100-box pile (bench/README.md) and did not
        // solve it either.
        s.lcp.ToSparse(&s.M);
        // The start basis must be nonsingular: not every corner of a spread support.
        VectorXd start;
        if (warm_plain) internal::IndependentNormalsWarmStart(model, a, x.warm_start, &start);
        info->solver =
            SolveSparseLemke(s.M, s.lcp.q(), warm_plain ? &start : nullptr, lemke->options(), &z);
        // A run that misses the tolerance by round-off (a degenerate terminal basis: the 27-box
        // pile's cold run ended at residual 1.8e-8 against τ = 1.5e-8) is polished by solving
        // its basis {i : z_i > 0} once more, by the warm-basis QR (same acceptance tests).
        if (!info->solver.ok() && z.size() == m_plain && z.allFinite() && (z.array() > 0.0).any()) {
          const VectorXd terminal = z;
          SolverReport polished;
          if (SolveOnWarmBasis(s.lcp, s.lcp.q(), terminal, lemke->options(), &s.basis, &z,
                               &polished)) {
            polished.iterations = info->solver.iterations;
            polished.message = "re-solved the terminal basis of the sparse Lemke run (" +
                               info->solver.message + ")";
            info->solver = polished;
          }
        }
        if (!info->solver.ok()) {
          internal::SolverFailed(
              "LCP solver 'lemke' (sparse, " + std::to_string(m_plain) + " unknowns)", info);
          return;
        }
        solved = true;
      }
    }
  }
  const bool structured = solved;  // z solves s.lcp's LCP
  if (!solved) {
    LcpProblem& lcp = s.dense_lcp;
    BuildLcpInto(model, a, v_l, &v_star, &joints, &lcp);
    z.setZero(lcp.size());
    if (lcp.size() > 0) {
      const VectorXd* warm = x.warm_start.size() == lcp.size() ? &x.warm_start : nullptr;
      info->solver = solver_->Solve(lcp, warm, &z);
      if (!info->solver.ok()) {
        internal::SolverFailed("LCP solver '" + std::string(solver_->name()) + "'", info);
        return;
      }
    } else {
      info->solver.status = SolverStatus::kSolved;
    }
  }

  if (structured)
    s.lcp.VelocityAfter(z, &s.impulse, &s.dv, &s.v1);
  else
    internal::VelocityAfterWith(a, v_star, z, joints, &s.impulse, &s.product, &s.dv, &s.v1);
  // Lemke's basis is the next step's warm start: spread statically indeterminate normal impulses
  // over every touching contact, so that basis holds them all (spread_normals.h).
  if (lemke != nullptr) {
    internal::SpreadIndeterminateNormals(model, a, s.v1, h, velocity_level_, info->solver.tolerance,
                                         &z);
    if (m_plain >= kSparseStepMinSize && z.size() == m_plain)
      internal::SpreadIndeterminateNormalsGlobally(model, a, s.v1, h, velocity_level_,
                                                   info->solver.tolerance, &z);
  }
  if (!internal::CompleteStep(model, x, s.v1, h, &z, next, info)) return;
  if (ws) ws->contacts = a.contacts;  // a copy into its storage (the assembly is reused)
  info->ok = true;
  info->status = StepStatus::kOk;
}

}  // namespace vinci::sim
