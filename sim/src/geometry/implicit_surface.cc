// Convex implicit functions, the implicit form of the scene shapes, and closest points of two
// intersections of convex implicit functions (see implicit_surface.h).
#include "vinci/sim/geometry/implicit_surface.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "implicit_set_into.h"
#include "vinci/sim/solvers/mcp.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ρ of the ellipsoid/superquadric forms: the geometric mean of the semi-axes used.
double MeanRadius(const Vector3d& a, int n) {
  return n == 3 ? std::cbrt(a.x() * a.y() * a.z()) : std::sqrt(a.x() * a.y());
}

// f, ∇f, ∇²f of the function in its own frame F (ξ = p_F). Outputs may be null.
void EvaluateInFunctionFrame(const ImplicitFunction& fn, const Vector3d& xi, double* f, Vector3d* g,
                             Matrix3d* H) {
  switch (fn.type) {
    case ImplicitType::kHalfspace:
    case ImplicitType::kHalfPlane: {
      const int axis = fn.type == ImplicitType::kHalfspace ? 2 : 1;
      if (f) *f = xi[axis];
      if (g) *g = Vector3d::Unit(axis);
      if (H) H->setZero();
      return;
    }
    case ImplicitType::kSphere:
    case ImplicitType::kCylinderSide:
    case ImplicitType::kDisc: {
      const double r = fn.radii.x();
      Vector3d x = xi;
      if (fn.type != ImplicitType::kSphere) x.z() = 0.0;
      if (f) *f = (x.squaredNorm() - r * r) / (2.0 * r);
      if (g) *g = x / r;
      if (H) {
        *H = Matrix3d::Identity() / r;
        if (fn.type != ImplicitType::kSphere) (*H)(2, 2) = 0.0;
      }
      return;
    }
    case ImplicitType::kEllipsoid:
    case ImplicitType::kEllipse:
    case ImplicitType::kSuperquadric:
    case ImplicitType::kSuperellipse: {
      const int n =
          (fn.type == ImplicitType::kEllipsoid || fn.type == ImplicitType::kSuperquadric) ? 3 : 2;
      const double e = (fn.type == ImplicitType::kEllipsoid || fn.type == ImplicitType::kEllipse)
                           ? 2.0
                           : fn.exponent;
      const double rho = MeanRadius(fn.radii, n);
      double sum = 0.0;
      if (g) g->setZero();
      if (H) H->setZero();
      for (int i = 0; i < n; ++i) {
        const double a = fn.radii[i];
        const double u = xi[i] / a, au = std::abs(u);
        if (e == 2.0) {
          sum += u * u;
          if (g) (*g)[i] = rho * u / a;
          if (H) (*H)(i, i) = rho / (a * a);
        } else {
          const double p2 = std::pow(au, e - 2.0);  // |u|^(e−2)
          sum += p2 * au * au;
          if (g) (*g)[i] = rho * p2 * u / a;  // ρ |u|^(e−1) sign(u) / a
          if (H) (*H)(i, i) = rho * (e - 1.0) * p2 / (a * a);
        }
      }
      if (f) *f = rho / e * (sum - 1.0);
      return;
    }
  }
  throw std::logic_error("ImplicitFunction: unknown ImplicitType");
}

// An orthonormal frame at p whose axis `axis` (2 = z, 1 = y) is the unit vector n; for y
// (planar use) the frame is a rotation about z.
Isometry3d FrameWithAxis(const Vector3d& n, const Vector3d& p, int axis) {
  Isometry3d X = Isometry3d::Identity();
  if (axis == 1) {
    X.linear() << n.y(), n.x(), 0.0, -n.x(), n.y(), 0.0, 0.0, 0.0, 1.0;
  } else {
    Eigen::Index i = 0;
    n.cwiseAbs().minCoeff(&i);
    const Vector3d t1 = n.cross(Vector3d::Unit(i)).normalized();
    X.linear().col(0) = t1;
    X.linear().col(1) = n.cross(t1);
    X.linear().col(2) = n;
  }
  X.translation() = p;
  return X;
}

ImplicitFunction Function(ImplicitType type, const Isometry3d& X_SF, const Vector3d& radii,
                          double exponent = 2.0) {
  ImplicitFunction f;
  f.type = type;
  f.X_SF = X_SF;
  f.radii = radii;
  f.exponent = exponent;
  return f;
}

Isometry3d Translation(const Vector3d& p) {
  Isometry3d X = Isometry3d::Identity();
  X.translation() = p;
  return X;
}

[[noreturn]] void ThrowShape(const Shape& s, const std::string& what) {
  throw std::invalid_argument(std::string("MakeImplicitSet: ") + ShapeKeyword(s.type) + " shape '" +
                              s.name + "': " + what);
}

void RequirePositive(const Shape& s, const char* field, double v) {
  if (!(v > 0.0) || !std::isfinite(v))
    ThrowShape(s, std::string(field) + " = " + FormatNumber(v) + ", expected a number > 0");
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// ImplicitFunction / ImplicitSet

void ImplicitFunction::Evaluate(const Vector3d& p_S, double* f, Vector3d* grad,
                                Matrix3d* hess) const {
  const Matrix3d& R = X_SF.linear();
  const Vector3d xi = R.transpose() * (p_S - X_SF.translation());
  Vector3d g_F;
  Matrix3d H_F;
  EvaluateInFunctionFrame(*this, xi, f, grad ? &g_F : nullptr, hess ? &H_F : nullptr);
  if (grad) *grad = R * g_F;
  if (hess) *hess = R * H_F * R.transpose();
}

double ImplicitFunction::Value(const Vector3d& p_S) const {
  double f = 0.0;
  Evaluate(p_S, &f, nullptr, nullptr);
  return f;
}

Vector3d ImplicitFunction::Gradient(const Vector3d& p_S) const {
  Vector3d g;
  Evaluate(p_S, nullptr, &g, nullptr);
  return g;
}

Matrix3d ImplicitFunction::Hessian(const Vector3d& p_S) const {
  Matrix3d H;
  Evaluate(p_S, nullptr, nullptr, &H);
  return H;
}

double ImplicitSet::Value(const Vector3d& p_S, int* active) const {
  double best = -kInf;
  int arg = -1;
  for (std::size_t k = 0; k < functions.size(); ++k) {
    const double v = functions[k].Value(p_S);
    if (v > best) best = v, arg = static_cast<int>(k);
  }
  if (active) *active = arg;
  return best;
}

bool ImplicitSet::Contains(const Vector3d& p_S, double tol) const {
  for (const ImplicitFunction& f : functions)
    if (!(f.Value(p_S) <= tol)) return false;
  return true;
}

// ---------------------------------------------------------------------------------------------
// MakeImplicitSet

void MakeImplicitSetInto(const Shape& s, ImplicitSet* set_out) {
  ImplicitSet& set = *set_out;
  set.functions.clear();
  set.vertices_S.clear();
  set.bounding_radius = 0.0;
  set.center_S.setZero();
  set.from_shape = true;
  set.shape_type = s.type;
  set.dim = IsPlanar(s.type) ? Dim::kPlanar : Dim::kSpatial;
  const Isometry3d I = Isometry3d::Identity();
  switch (s.type) {
    case ShapeType::kHalfSpace:
      set.functions.push_back(Function(ImplicitType::kHalfspace, I, Vector3d::Ones()));
      set.bounding_radius = kInf;
      return;
    case ShapeType::kHalfPlane:
      set.functions.push_back(Function(ImplicitType::kHalfPlane, I, Vector3d::Ones()));
      set.bounding_radius = kInf;
      return;
    case ShapeType::kSphere:
    case ShapeType::kDisc: {
      RequirePositive(s, "radius", s.radius);
      const ImplicitType t =
          s.type == ShapeType::kSphere ? ImplicitType::kSphere : ImplicitType::kDisc;
      set.functions.push_back(Function(t, I, Vector3d::Constant(s.radius)));
      set.bounding_radius = s.radius;
      return;
    }
    case ShapeType::kBox: {
      for (int c = 0; c < 3; ++c) RequirePositive(s, "half_extents", s.half_extents[c]);
      for (int c = 0; c < 3; ++c)
        for (double sign : {1.0, -1.0}) {
          const Vector3d n = sign * Vector3d::Unit(c);
          set.functions.push_back(Function(ImplicitType::kHalfspace,
                                           FrameWithAxis(n, s.half_extents[c] * n, 2),
                                           Vector3d::Ones()));
        }
      for (int k = 0; k < 8; ++k)
        set.vertices_S.push_back(s.half_extents.cwiseProduct(
            Vector3d(k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0)));
      set.bounding_radius = s.half_extents.norm();
      return;
    }
    case ShapeType::kPolyhedron: {
      Shape prepared = s;
      if (prepared.faces.empty() || prepared.hull_vertices.empty()) PrepareShape(&prepared);
      Vector3d c = Vector3d::Zero();
      double r = 0.0;
      for (int i : prepared.hull_vertices) {
        c += prepared.vertices[i];
        r = std::max(r, prepared.vertices[i].norm());
      }
      set.center_S = c / static_cast<double>(prepared.hull_vertices.size());
      for (int i : prepared.hull_vertices) set.vertices_S.push_back(prepared.vertices[i]);
      for (const HullFace& f : prepared.faces)
        set.functions.push_back(Function(ImplicitType::kHalfspace,
                                         FrameWithAxis(f.normal_S, f.offset * f.normal_S, 2),
                                         Vector3d::Ones()));
      set.bounding_radius = r;
      return;
    }
    case ShapeType::kPolygon: {
      const int n = static_cast<int>(s.vertices.size());
      if (n < 3) ThrowShape(s, "needs at least 3 vertices, got " + std::to_string(n));
      double area2 = 0.0, r = 0.0;
      Vector3d c = Vector3d::Zero();
      for (int i = 0; i < n; ++i) {
        area2 += Cross2(s.vertices[i].head<2>(), s.vertices[(i + 1) % n].head<2>());
        c += Vector3d(s.vertices[i].x(), s.vertices[i].y(), 0.0);
        r = std::max(r, s.vertices[i].head<2>().norm());
      }
      if (!(area2 > 0.0)) ThrowShape(s, "vertices must be counter-clockwise with positive area");
      for (int i = 0; i < n; ++i) {
        const Vector2d p = s.vertices[i].head<2>(), q = s.vertices[(i + 1) % n].head<2>();
        const Vector2d e = q - p;
        if (!(e.norm() > 0.0)) ThrowShape(s, "repeated vertex " + std::to_string(i));
        const Vector2d out = Vector2d(e.y(), -e.x()).normalized();
        set.functions.push_back(
            Function(ImplicitType::kHalfPlane,
                     FrameWithAxis(Vector3d(out.x(), out.y(), 0.0), Vector3d(p.x(), p.y(), 0.0), 1),
                     Vector3d::Ones()));
      }
      set.center_S = c / n;
      for (const Vector3d& v : s.vertices) set.vertices_S.emplace_back(v.x(), v.y(), 0.0);
      set.bounding_radius = r;
      return;
    }
    case ShapeType::kEllipsoid:
    case ShapeType::kSuperquadric:
    case ShapeType::kEllipse:
    case ShapeType::kSuperellipse: {
      const bool planar = IsPlanar(s.type);
      const int n = planar ? 2 : 3;
      for (int c = 0; c < n; ++c) RequirePositive(s, "half_extents", s.half_extents[c]);
      Vector3d radii = s.half_extents;
      if (planar) radii.z() = 1.0;
      const bool super = s.type == ShapeType::kSuperquadric || s.type == ShapeType::kSuperellipse;
      if (super && !(s.exponent >= 2.0 && std::isfinite(s.exponent)))
        ThrowShape(s, "exponent = " + FormatNumber(s.exponent) + ", expected a number >= 2");
      const ImplicitType t = s.type == ShapeType::kEllipsoid      ? ImplicitType::kEllipsoid
                             : s.type == ShapeType::kSuperquadric ? ImplicitType::kSuperquadric
                             : s.type == ShapeType::kEllipse      ? ImplicitType::kEllipse
                                                                  : ImplicitType::kSuperellipse;
      set.functions.push_back(Function(t, I, radii, super ? s.exponent : 2.0));
      // The superball Σ|u_i|^e ≤ 1 lies in the ball of radius n^(1/2 − 1/e).
      const double amax = radii.head(n).maxCoeff();
      set.bounding_radius = amax * (super ? std::pow(n, 0.5 - 1.0 / s.exponent) : 1.0);
      return;
    }
    case ShapeType::kCylinder: {
      RequirePositive(s, "radius", s.radius);
      RequirePositive(s, "half_length", s.half_length);
      set.functions.push_back(
          Function(ImplicitType::kCylinderSide, I, Vector3d::Constant(s.radius)));
      for (double sign : {1.0, -1.0})
        set.functions.push_back(Function(
            ImplicitType::kHalfspace,
            FrameWithAxis(sign * Vector3d::UnitZ(), sign * s.half_length * Vector3d::UnitZ(), 2),
            Vector3d::Ones()));
      set.bounding_radius = std::hypot(s.radius, s.half_length);
      return;
    }
    case ShapeType::kLens: {
      RequirePositive(s, "radius", s.radius);
      RequirePositive(s, "half_length", s.half_length);
      if (s.half_length > s.radius)
        ThrowShape(s, "half_length = " + FormatNumber(s.half_length) + ", expected <= radius");
      const double R = s.radius, c = R - s.half_length;
      // The upper face is the sphere centred below the origin, and vice versa.
      for (double sign : {-1.0, 1.0})
        set.functions.push_back(Function(ImplicitType::kSphere,
                                         Translation(sign * c * Vector3d::UnitZ()),
                                         Vector3d::Constant(R)));
      set.bounding_radius = std::sqrt(std::max(0.0, R * R - c * c));
      return;
    }
    case ShapeType::kCapsule:
    case ShapeType::kSegment:
      ThrowShape(s, "has no implicit form (not an intersection of convex implicit functions)");
    case ShapeType::kConcavePolygon:
      ThrowShape(s, "has no implicit form (it is not convex)");
  }
  throw std::logic_error("MakeImplicitSet: unknown ShapeType");
}

ImplicitSet MakeImplicitSet(const Shape& shape) {
  ImplicitSet set;
  MakeImplicitSetInto(shape, &set);
  return set;
}

// ---------------------------------------------------------------------------------------------
// ClosestPoints

namespace {

// One set posed in the world, evaluated in scaled world coordinates x̃ = (x − O)/L (d = 2 or
// 3 components): f̃ = f/L, ∇̃f = ∇f (world), ∇̃²f = L ∇²f.
struct PosedSet {
  const ImplicitSet* set;
  Isometry3d X_WS;
  Vector3d origin;  // O
  double L;
  int d;

  int size() const { return static_cast<int>(set->functions.size()); }
  Vector3d World(const VectorXd& x) const {
    Vector3d p = origin;
    p.head(d) += L * x;
    return p;
  }
  void Eval(int k, const VectorXd& x, double* f, VectorXd* g, MatrixXd* H) const {
    const Vector3d p_S = X_WS.inverse() * World(x);
    double fv;
    Vector3d gS;
    Matrix3d HS;
    set->functions[k].Evaluate(p_S, &fv, &gS, H ? &HS : nullptr);
    const Matrix3d& R = X_WS.linear();
    if (f) *f = fv / L;
    if (g) *g = (R * gS).head(d);
    if (H) *H = L * (R * HS * R.transpose()).topLeftCorner(d, d);
  }
};

// Phase 1: min ½‖a1 − a2‖² + (ε/2)(‖a1 − c1‖² + ‖a2 − c2‖²) s.t. f_k(a1) ≤ 0, g_j(a2) ≤ 0,
// as an MCP in z = (a1, a2, λ, μ). Returns the solver report.
SolverReport SolveDistance(const PosedSet& A, const PosedSet& B, double eps, const VectorXd& c1,
                           const VectorXd& c2, VectorXd* z, const McpSolver& solver) {
  const int d = A.d, ma = A.size(), mb = B.size(), n = 2 * d + ma + mb;
  McpProblem p;
  p.lower = VectorXd::Constant(n, -kInf);
  p.upper = VectorXd::Constant(n, kInf);
  p.lower.tail(ma + mb).setZero();
  p.evaluate = [&](const VectorXd& zz, VectorXd* F, MatrixXd* J) {
    const VectorXd a1 = zz.head(d), a2 = zz.segment(d, d);
    F->resize(n);
    F->head(d) = a1 - a2 + eps * (a1 - c1);
    F->segment(d, d) = a2 - a1 + eps * (a2 - c2);
    if (J) {
      J->setZero(n, n);
      J->topLeftCorner(d, d).diagonal().setConstant(1.0 + eps);
      J->block(d, d, d, d).diagonal().setConstant(1.0 + eps);
      J->block(0, d, d, d).diagonal().setConstant(-1.0);
      J->block(d, 0, d, d).diagonal().setConstant(-1.0);
    }
    double f;
    VectorXd g;
    MatrixXd H;
    for (int s = 0; s < 2; ++s) {
      const PosedSet& S = s == 0 ? A : B;
      const VectorXd& a = s == 0 ? a1 : a2;
      const int row = s * d, off = 2 * d + (s == 0 ? 0 : ma);
      for (int k = 0; k < S.size(); ++k) {
        const double l = zz[off + k];
        S.Eval(k, a, &f, &g, J ? &H : nullptr);
        F->segment(row, d) += l * g;
        (*F)[off + k] = -f;
        if (J) {
          J->block(row, row, d, d) += l * H;
          J->block(row, off + k, d, 1) = g;
          J->block(off + k, row, 1, d) = -g.transpose();
        }
      }
    }
  };
  return solver.Solve(p, z);
}

// Phase 2: the support-point (common normal) system in z = (a1, a2, u, s, λ, μ):
//   −u − ε(a1 − c1) − Σ λ_k ∇f_k(a1) = 0      a1 supports A in direction −u
//    u − ε(a2 − c2) − Σ μ_j ∇g_j(a2) = 0      a2 supports B in direction +u
//   a1 − a2 − s u = 0,  (u·u − 1)/2 = 0,  0 ≤ λ ⊥ −f(a1) ≥ 0,  0 ≤ μ ⊥ −g(a2) ≥ 0.
// s is the signed distance along the unit normal u (B to A); well posed when touching or
// overlapping, where the distance problem is degenerate.
SolverReport SolveNormal(const PosedSet& A, const PosedSet& B, double eps, const VectorXd& c1,
                         const VectorXd& c2, VectorXd* z, const McpSolver& solver) {
  const int d = A.d, ma = A.size(), mb = B.size(), n = 3 * d + 1 + ma + mb;
  const int iu = 2 * d, is = 3 * d, il = 3 * d + 1;
  McpProblem p;
  p.lower = VectorXd::Constant(n, -kInf);
  p.upper = VectorXd::Constant(n, kInf);
  p.lower.tail(ma + mb).setZero();
  p.evaluate = [&](const VectorXd& zz, VectorXd* F, MatrixXd* J) {
    const VectorXd a1 = zz.head(d), a2 = zz.segment(d, d), u = zz.segment(iu, d);
    const double s = zz[is];
    F->resize(n);
    F->head(d) = -u - eps * (a1 - c1);
    F->segment(d, d) = u - eps * (a2 - c2);
    F->segment(iu, d) = a1 - a2 - s * u;
    (*F)[is] = 0.5 * (u.squaredNorm() - 1.0);
    if (J) {
      J->setZero(n, n);
      J->topLeftCorner(d, d).diagonal().setConstant(-eps);
      J->block(0, iu, d, d).diagonal().setConstant(-1.0);
      J->block(d, d, d, d).diagonal().setConstant(-eps);
      J->block(d, iu, d, d).diagonal().setConstant(1.0);
      J->block(iu, 0, d, d).diagonal().setConstant(1.0);
      J->block(iu, d, d, d).diagonal().setConstant(-1.0);
      J->block(iu, iu, d, d).diagonal().setConstant(-s);
      J->block(iu, is, d, 1) = -u;
      J->block(is, iu, 1, d) = u.transpose();
    }
    double f;
    VectorXd g;
    MatrixXd H;
    for (int side = 0; side < 2; ++side) {
      const PosedSet& S = side == 0 ? A : B;
      const VectorXd& a = side == 0 ? a1 : a2;
      const int row = side * d, off = il + (side == 0 ? 0 : ma);
      for (int k = 0; k < S.size(); ++k) {
        const double l = zz[off + k];
        S.Eval(k, a, &f, &g, J ? &H : nullptr);
        F->segment(row, d) -= l * g;
        (*F)[off + k] = -f;
        if (J) {
          J->block(row, row, d, d) -= l * H;
          J->block(row, off + k, d, 1) = -g;
          J->block(off + k, row, 1, d) = -g.transpose();
        }
      }
    }
  };
  return solver.Solve(p, z);
}

// Index of the function with the largest multiplier (scaled by its gradient norm at a).
int Active(const PosedSet& S, const VectorXd& a, const VectorXd& mult) {
  int best = 0;
  double best_w = -1.0;
  VectorXd g;
  for (int k = 0; k < S.size(); ++k) {
    S.Eval(k, a, nullptr, &g, nullptr);
    const double w = mult[k] * g.norm();
    if (w > best_w) best_w = w, best = k;
  }
  return best;
}

// A point of the set near the world point `toward`: the set's centre, or for an unbounded set
// the projection of `toward` onto its (linear) functions.
Vector3d StartPoint(const ImplicitSet& s, const Isometry3d& X_WS, const Vector3d& toward) {
  if (std::isfinite(s.bounding_radius)) return X_WS * s.center_S;
  Vector3d p = X_WS.inverse() * toward;
  for (const ImplicitFunction& f : s.functions) {
    double v;
    Vector3d g;
    f.Evaluate(p, &v, &g, nullptr);
    if (v > 0.0 && g.squaredNorm() > 0.0) p -= v * g / g.squaredNorm();
  }
  return X_WS * p;
}

// The support point of a bounded set in world direction d_W (argmax of d·x over the set), if
// it has a closed form: a single sphere/ellipsoid/superquadric/disc/ellipse/superellipse, or a
// polytope with listed vertices.
bool SupportPoint(const ImplicitSet& s, const Isometry3d& X_WS, const Vector3d& d_W,
                  Vector3d* p_W) {
  const Vector3d d_S = X_WS.linear().transpose() * d_W;
  if (!s.vertices_S.empty()) {
    // A face or edge that supports the set (within round-off) gives its vertex average (the
    // face centre of a box), not an arbitrary corner: a stable witness for a resting face.
    double best = -kInf;
    for (const Vector3d& v : s.vertices_S) best = std::max(best, d_S.dot(v));
    const double tol = 1e-9 * s.bounding_radius * d_S.norm();
    Vector3d sum = Vector3d::Zero();
    int count = 0;
    for (const Vector3d& v : s.vertices_S)
      if (d_S.dot(v) >= best - tol) sum += v, ++count;
    *p_W = X_WS * (sum / count);
    return true;
  }
  if (s.from_shape && s.shape_type == ShapeType::kCylinder && s.functions.size() == 3) {
    // Axial extreme ±L (mid-height when the direction is radial), radial extreme r along the
    // radial part (the cap centre when the direction is axial): the centre of a supporting
    // line or cap, like a polytope's face centre.
    const double r = s.functions[0].radii.x(), L = s.functions[1].X_SF.translation().norm();
    const double tol = 1e-12 * d_S.norm();
    Vector3d x = Vector3d::Zero();
    if (d_S.head<2>().norm() > tol) x.head<2>() = r * d_S.head<2>().normalized();
    if (std::abs(d_S.z()) > tol) x.z() = std::copysign(L, d_S.z());
    *p_W = X_WS * x;
    return true;
  }
  if (s.from_shape && s.shape_type == ShapeType::kLens && s.functions.size() == 2) {
    // Caps: the sphere centred at ∓c e_z for a direction with ±z component; rim: the circle of
    // radius ρ at z = 0.
    const double R = s.functions[0].radii.x(), c = s.functions[0].X_SF.translation().norm();
    const double rho = std::sqrt(std::max(0.0, R * R - c * c));
    if (!(d_S.norm() > 0.0)) return false;
    const Vector3d u = d_S.normalized();
    if (R * u.head<2>().norm() <= rho && u.z() != 0.0) {
      *p_W = X_WS * (Vector3d(0.0, 0.0, -std::copysign(c, u.z())) + R * u);
    } else {
      *p_W =
          X_WS * Vector3d(rho * u.x() / u.head<2>().norm(), rho * u.y() / u.head<2>().norm(), 0.0);
    }
    return true;
  }
  if (s.functions.size() != 1) return false;
  const ImplicitFunction& f = s.functions[0];
  Vector3d w = f.X_SF.linear().transpose() * d_S;  // direction in the function frame
  const bool planar = IsPlanar(f.type);
  if (planar) w.z() = 0.0;
  const int n = planar ? 2 : 3;
  Vector3d x_F = Vector3d::Zero();
  switch (f.type) {
    case ImplicitType::kSphere:
    case ImplicitType::kDisc:
      if (!(w.norm() > 0.0)) return false;
      x_F = f.radii.x() * w.normalized();
      break;
    case ImplicitType::kEllipsoid:
    case ImplicitType::kEllipse: {
      Vector3d a = f.radii;
      if (planar) a.z() = 0.0;
      const Vector3d aw = a.cwiseProduct(w);
      if (!(aw.norm() > 0.0)) return false;
      x_F = a.cwiseProduct(aw) / aw.norm();
      break;
    }
    case ImplicitType::kSuperquadric:
    case ImplicitType::kSuperellipse: {
      // Maximize Σ v_i y_i over ‖y‖_e ≤ 1 (v = a∘w, x = a∘y): y_i = sign v_i |v_i|^{q−1} /
      // ‖v‖_q^{q−1}, 1/e + 1/q = 1.
      const double q = f.exponent / (f.exponent - 1.0);
      double big = 0.0;
      for (int i = 0; i < n; ++i) big = std::max(big, std::abs(f.radii[i] * w[i]));
      if (!(big > 0.0)) return false;
      double norm_q = 0.0;
      for (int i = 0; i < n; ++i) norm_q += std::pow(std::abs(f.radii[i] * w[i]) / big, q);
      norm_q = std::pow(norm_q, 1.0 / q);  // ‖v/big‖_q
      for (int i = 0; i < n; ++i) {
        const double v = f.radii[i] * w[i] / big;
        x_F[i] = f.radii[i] * std::copysign(std::pow(std::abs(v), q - 1.0), v) /
                 std::pow(norm_q, q - 1.0);
      }
      break;
    }
    default:
      return false;
  }
  *p_W = X_WS * (f.X_SF * x_F);
  return true;
}

// Active function at a (shape-frame point on the boundary) for a contact whose outward normal
// from the set is o_S: among the functions vanishing there, the one whose normal is most
// aligned with o_S.
int ActiveAt(const ImplicitSet& s, const Vector3d& p_S, const Vector3d& o_S, double tol) {
  int best = 0;
  double best_c = -kInf;
  for (std::size_t k = 0; k < s.functions.size(); ++k) {
    double f;
    Vector3d g;
    s.functions[k].Evaluate(p_S, &f, &g, nullptr);
    if (std::abs(f) > tol || !(g.norm() > 0.0)) continue;
    const double c = o_S.dot(g) / g.norm();
    if (c > best_c) best_c = c, best = static_cast<int>(k);
  }
  return best;
}

// Closed-form closest points when they exist (see the header); false otherwise.
bool ClosedFormProximity(const ImplicitSet& a, const Isometry3d& X_WA, const ImplicitSet& b,
                         const Isometry3d& X_WB, ImplicitProximity* out) {
  auto single = [](const ImplicitSet& s, ImplicitType t1, ImplicitType t2) {
    return s.functions.size() == 1 && (s.functions[0].type == t1 || s.functions[0].type == t2);
  };
  const bool planar = a.dim == Dim::kPlanar;
  auto flat = [&](Vector3d v) {
    if (planar) v.z() = 0.0;
    return v;
  };
  // Two spheres/discs.
  if (single(a, ImplicitType::kSphere, ImplicitType::kDisc) &&
      single(b, ImplicitType::kSphere, ImplicitType::kDisc)) {
    const Vector3d ca = flat(X_WA * a.functions[0].X_SF.translation());
    const Vector3d cb = flat(X_WB * b.functions[0].X_SF.translation());
    const double ra = a.functions[0].radii.x(), rb = b.functions[0].radii.x();
    const Vector3d d = ca - cb;
    if (!(d.norm() > 1e-12 * (ra + rb))) return false;  // concentric: no unique normal
    out->n_W = d / d.norm();
    out->distance = d.norm() - ra - rb;
    out->a1_W = ca - ra * out->n_W;
    out->a2_W = cb + rb * out->n_W;
    out->active_a = out->active_b = 0;
    out->ok = true;
    return true;
  }
  // A half-space/half-plane against a set with a closed-form support point.
  for (int side = 0; side < 2; ++side) {
    const ImplicitSet& h = side == 0 ? b : a;  // the half-space
    const ImplicitSet& o = side == 0 ? a : b;  // the other set
    const Isometry3d& X_WH = side == 0 ? X_WB : X_WA;
    const Isometry3d& X_WO = side == 0 ? X_WA : X_WB;
    if (!single(h, ImplicitType::kHalfspace, ImplicitType::kHalfPlane)) continue;
    if (!std::isfinite(o.bounding_radius)) continue;
    const ImplicitFunction& f = h.functions[0];
    const Isometry3d X_WF = X_WH * f.X_SF;
    const Vector3d nh = flat(X_WF.linear().col(f.type == ImplicitType::kHalfspace ? 2 : 1));
    Vector3d p_o;
    if (!SupportPoint(o, X_WO, -nh, &p_o)) return false;
    p_o = flat(p_o);
    const double dist = nh.dot(p_o - flat(X_WF.translation()));
    const Vector3d p_h = p_o - dist * nh;
    const double tol = 1e-9 * o.bounding_radius;
    const int act = ActiveAt(o, X_WO.inverse() * p_o, -(X_WO.linear().transpose() * nh), tol);
    out->distance = dist;
    if (side == 0) {  // A is the other set, B the half-space: n from B to A is +nh
      out->a1_W = p_o, out->a2_W = p_h, out->n_W = nh;
      out->active_a = act, out->active_b = 0;
    } else {
      out->a1_W = p_h, out->a2_W = p_o, out->n_W = -nh;
      out->active_a = 0, out->active_b = act;
    }
    out->ok = true;
    return true;
  }
  return false;
}

}  // namespace

ImplicitProximity ClosestPoints(const ImplicitSet& a, const Isometry3d& X_WA, const ImplicitSet& b,
                                const Isometry3d& X_WB) {
  if (a.dim != b.dim) throw std::invalid_argument("ClosestPoints: a planar and a spatial set");
  if (a.functions.empty() || b.functions.empty())
    throw std::invalid_argument("ClosestPoints: a set without functions");
  const bool fa = std::isfinite(a.bounding_radius), fb = std::isfinite(b.bounding_radius);
  if (!fa && !fb) throw std::invalid_argument("ClosestPoints: two unbounded sets");
  const int d = a.dim == Dim::kPlanar ? 2 : 3;
  {
    ImplicitProximity closed;
    if (ClosedFormProximity(a, X_WA, b, X_WB, &closed)) return closed;
  }

  // Scale: the larger finite bounding radius; origin between the start points.
  const double L = std::max(fa ? a.bounding_radius : 0.0, fb ? b.bounding_radius : 0.0);
  if (!(L > 0.0)) throw std::invalid_argument("ClosestPoints: a set of zero size");
  Vector3d pa = fa ? Vector3d(X_WA * a.center_S) : Vector3d::Zero();
  Vector3d pb = StartPoint(b, X_WB, fa ? pa : Vector3d(X_WB * b.center_S));
  if (!fa) pa = StartPoint(a, X_WA, pb);
  if (d == 2) pa.z() = pb.z() = 0.0;
  const Vector3d origin = 0.5 * (pa + pb);
  const PosedSet A{&a, X_WA, origin, L, d}, B{&b, X_WB, origin, L, d};
  const int ma = A.size(), mb = B.size();

  McpOptions opt;
  opt.tolerance = 1e-13;
  opt.max_iterations = 50;
  const McpSolver solver(opt);
  // Proximal point passes: each solve adds (ε/2)‖a − c‖² (c = the previous witnesses), which
  // makes flat contacts (a face on a face, a cylinder side on a plane) well posed; the weight
  // falls 100× per pass to kProxMin so that nearly flat contacts (a support point that moves far
  // for a tiny tilt) are reached in a few passes. Converged when the proximal term's share of
  // the stationarity residual, ε‖a − c‖, is below kProxResidual (scaled units).
  constexpr double kProx = 1e-6, kProxMin = 1e-12, kProxResidual = 1e-13;
  constexpr double kAcceptResidual = 1e-8;  // scaled natural residual of an accepted pass
  constexpr int kMaxPasses = 25;

  ImplicitProximity out;
  // Phase 1: distance (convex; reliable from the centres).
  VectorXd z1 = VectorXd::Zero(2 * d + ma + mb);
  z1.head(d) = ((pa - origin) / L).head(d);
  z1.segment(d, d) = ((pb - origin) / L).head(d);
  bool ok1 = false;
  double eps = kProx;
  for (int pass = 0; pass < kMaxPasses; ++pass, eps = std::max(kProxMin, 1e-2 * eps)) {
    const VectorXd c1 = z1.head(d), c2 = z1.segment(d, d);
    const SolverReport r = SolveDistance(A, B, eps, c1, c2, &z1, solver);
    out.iterations += r.iterations;
    // A nearly degenerate corner (a constraint with a tiny multiplier) can stall the solver
    // just short of its tolerance: such a pass is accepted, and ends the passes.
    ok1 = r.residual <= kAcceptResidual;
    if (!r.ok()) break;
    if (eps * std::max((z1.head(d) - c1).norm(), (z1.segment(d, d) - c2).norm()) < kProxResidual)
      break;
    if (pass + 1 == kMaxPasses) ok1 = false;  // still moving
  }
  VectorXd a1 = z1.head(d), a2 = z1.segment(d, d);
  const double d1 = (a1 - a2).norm();

  // Phase 2: common normal, from phase 1's direction (or the centres' when overlapping).
  VectorXd u = a1 - a2;
  if (!(d1 > 1e-6)) u = ((pa - pb) / L).head(d);
  if (!(u.norm() > 1e-12)) u = VectorXd::Unit(d, d - 1);
  u.normalize();
  VectorXd z2 = VectorXd::Zero(3 * d + 1 + ma + mb);
  z2.head(d) = a1;
  z2.segment(d, d) = a2;
  z2.segment(2 * d, d) = u;
  z2[3 * d] = u.dot(a1 - a2);
  // Multipliers consistent with phase 1: λ_1 ∇f = −(a1 − a2) = −s u, so λ_2 = λ_1 / s.
  if (d1 > 1e-6) {
    z2.segment(3 * d + 1, ma) = z1.segment(2 * d, ma) / d1;
    z2.tail(mb) = z1.tail(mb) / d1;
  }
  bool ok2 = false;
  eps = kProx;
  for (int pass = 0; pass < kMaxPasses; ++pass, eps = std::max(kProxMin, 1e-2 * eps)) {
    const VectorXd c1 = z2.head(d), c2 = z2.segment(d, d);
    const SolverReport r = SolveNormal(A, B, eps, c1, c2, &z2, solver);
    out.iterations += r.iterations;
    // A nearly degenerate corner (a constraint with a tiny multiplier) can stall the solver
    // just short of its tolerance: such a pass is accepted, and ends the passes.
    ok2 = r.residual <= kAcceptResidual;
    if (!r.ok()) break;
    if (eps * std::max((z2.head(d) - c1).norm(), (z2.segment(d, d) - c2).norm()) < kProxResidual)
      break;
    if (pass + 1 == kMaxPasses) ok2 = false;
  }
  // Bounds: phase 1's |a1 − a2| is an upper bound on the distance (feasible points), phase 2's
  // s = −h_A(−u) − h_B(u) a lower bound (support points along some u). Phase 2 found another
  // stationary point of the support-function problem if s falls clearly below phase 1's
  // distance; near touching, phase 1 (degenerate there) may stop short, so the margin is wide.
  const double s2 = z2[3 * d];
  const bool use2 = ok2 && (!(d1 > 1e-6) || s2 >= d1 - 1e-3);
  VectorXd la, lb;
  if (use2) {
    a1 = z2.head(d);
    a2 = z2.segment(d, d);
    u = z2.segment(2 * d, d);
    out.distance = s2 * L;
    la = z2.segment(3 * d + 1, ma);
    lb = z2.tail(mb);
    out.ok = true;
  } else {
    a1 = z1.head(d);
    a2 = z1.segment(d, d);
    u = (a1 - a2) / std::max(d1, 1e-300);
    out.distance = d1 * L;
    la = z1.segment(2 * d, ma);
    lb = z1.tail(mb);
    out.ok = ok1 && d1 > 1e-6;
  }
  out.a1_W = A.World(a1);
  out.a2_W = B.World(a2);
  out.n_W.setZero();
  out.n_W.head(d) = u.normalized();
  out.active_a = Active(A, a1, la);
  out.active_b = Active(B, a2, lb);
  return out;
}

}  // namespace vinci::sim
