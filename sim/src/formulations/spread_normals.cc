#include "spread_normals.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <vector>

namespace vinci::sim::internal {
namespace {

// Singular values of a pair's normal columns below this fraction of the largest span its null
// space (four corners of a face with one normal: exactly rank 3, so the fourth is round-off).
constexpr double kNullSpaceTol = 1e-10;

struct SpreadScratch {
  // One pair's buffers, kept per shape of its J (rows × members) so that pairs of different
  // shapes do not reallocate each other's (Eigen's matrices and SVD have no spare capacity).
  struct PairBuffers {
    int rows = 0, m = 0;
    Eigen::MatrixXd J;
    Eigen::VectorXd p, target, projected;
    Eigen::JacobiSVD<Eigen::MatrixXd> svd;
  };
  std::vector<int> members;
  SpreadEligibility eligibility;
  std::vector<PairBuffers> pairs;
  PairBuffers& For(int rows, int m) {
    for (PairBuffers& b : pairs)
      if (b.rows == rows && b.m == m) return b;
    pairs.emplace_back();
    pairs.back().rows = rows;
    pairs.back().m = m;
    return pairs.back();
  }
};

// The pair's normal columns of `members` restricted to its dynamic bodies' velocity blocks
// (false if neither body is dynamic).
bool PairColumns(const Scene& model, const StewartTrinkle::Assembly& a, int ba, int bb,
                 const std::vector<int>& members, Eigen::MatrixXd* J) {
  const int nvb = VelocitySize(model.dim);
  int rows = 0, offsets[2], nblocks = 0;
  for (int body : {ba, bb})
    if (body >= 0 && model.bodies[body].kind == BodyKind::kDynamic) {
      offsets[nblocks++] = model.index(body).v;
      rows += nvb;
    }
  if (rows == 0) return false;
  const int m = static_cast<int>(members.size());
  J->setZero(rows, m);
  for (int i = 0; i < m; ++i)
    for (SparseMatrixd::InnerIterator it(a.G_n, members[i]); it; ++it)
      for (int k = 0; k < nblocks; ++k)
        if (it.row() >= offsets[k] && it.row() < offsets[k] + nvb)
          (*J)(k * nvb + (it.row() - offsets[k]), i) = it.value();
  return true;
}

}  // namespace

void IndependentNormalsWarmStart(const Scene& model, const StewartTrinkle::Assembly& a,
                                 const VectorXd& z, VectorXd* out) {
  *out = z;
  const int nc = static_cast<int>(a.contacts.size());
  if (nc < 2 || z.size() < nc) return;
  std::vector<int> members;
  Eigen::MatrixXd J;
  for (int begin = 0; begin < nc;) {
    const int ba = a.contacts[begin].body_a, bb = a.contacts[begin].body_b;
    int end = begin + 1;
    while (end < nc && a.contacts[end].body_a == ba && a.contacts[end].body_b == bb) ++end;
    members.clear();
    for (int c = begin; c < end; ++c)
      if (z[c] > 0.0) members.push_back(c);
    begin = end;
    if (members.size() < 2 || !PairColumns(model, a, ba, bb, members, &J)) continue;
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(J);
    qr.setThreshold(kNullSpaceTol);
    const Eigen::Index rank = qr.rank();
    for (Eigen::Index i = rank; i < static_cast<Eigen::Index>(members.size()); ++i)
      (*out)[members[qr.colsPermutation().indices()(i)]] = 0.0;
  }
}

void SpreadIndeterminateNormals(const Scene& model, const StewartTrinkle::Assembly& a,
                                const VectorXd& v1, double h, bool velocity_level, double w_tol,
                                VectorXd* z) {
  const int nc = static_cast<int>(a.contacts.size());
  const int nf = nc * a.nd;
  if (nc < 2 || z->size() < nc + nf + nc) return;
  // Buffers only (no result depends on them): one set per thread.
  thread_local SpreadScratch s;
  bool reset = false;  // s.eligibility reset for this call (on first use)
  const auto eligible = [&](int c) {
    return s.eligibility.Eligible(a, v1, *z, c, h, velocity_level, w_tol);
  };
  // Runs of consecutive contacts of one body pair (FindContacts orders contacts by body pair).
  for (int begin = 0; begin < nc;) {
    const int ba = a.contacts[begin].body_a, bb = a.contacts[begin].body_b;
    int end = begin + 1;
    while (end < nc && a.contacts[end].body_a == ba && a.contacts[end].body_b == bb) ++end;
    // Every contact of the run loaded: so is every member, and z stays as it is (below).
    bool all_loaded = true;
    for (int c = begin; c < end; ++c) all_loaded &= (*z)[c] > 0.0;
    if (all_loaded) {
      begin = end;
      continue;
    }
    if (!reset) {
      s.eligibility.Reset(a);
      reset = true;
    }
    s.members.clear();
    for (int c = begin; c < end; ++c)
      if (eligible(c)) s.members.push_back(c);
    begin = end;
    const int m = static_cast<int>(s.members.size());
    if (m < 2) continue;
    // Every touching contact already carries load (the basis holds them all): keep z as it is.
    int loaded = 0;
    for (int c : s.members) loaded += (*z)[c] > 0.0;
    if (loaded == m) continue;
    int rows = 0;  // PairColumns' row count
    for (int body : {ba, bb})
      if (body >= 0 && model.bodies[body].kind == BodyKind::kDynamic)
        rows += VelocitySize(model.dim);
    SpreadScratch::PairBuffers& b = s.For(rows, m);
    if (!PairColumns(model, a, ba, bb, s.members, &b.J)) continue;
    b.p.resize(m);
    double p_sum = 0.0;
    for (int i = 0; i < m; ++i) {
      b.p[i] = (*z)[s.members[i]];
      p_sum += b.p[i];
    }
    if (!(p_sum > 0.0)) continue;
    const Eigen::JacobiSVD<Eigen::MatrixXd>& svd = b.svd.compute(b.J, Eigen::ComputeFullV);
    const auto& sv = svd.singularValues();
    if (sv.size() == 0 || !(sv[0] > 0.0)) continue;
    int rank = 0;
    while (rank < sv.size() && sv[rank] > kNullSpaceTol * sv[0]) ++rank;
    if (rank >= m) continue;  // the pair's impulses are determined: nothing to choose
    // Minimum-norm impulses with the same G p: the projection of p on the row space of J.
    const auto V_r = svd.matrixV().leftCols(rank);
    // (The inner product into a buffer first, as Eigen evaluates the nested product.)
    b.projected.noalias() = V_r.transpose() * b.p;
    b.target.noalias() = V_r * b.projected;
    // Go from p towards it as far as p ≥ 0 and every friction row μ p_n − Σ p_f ≥ 0 allow.
    double t = 1.0;
    for (int i = 0; i < m && t > 0.0; ++i) {
      const double d = b.target[i] - b.p[i];
      if (!(d < 0.0)) continue;
      t = std::min(t, b.p[i] / -d);
      const int c = s.members[i];
      double slack = a.mu[c] * b.p[i];
      for (int j = 0; j < a.nd; ++j) slack -= (*z)[nc + c * a.nd + j];
      if (a.mu[c] > 0.0)
        t = std::min(t, std::max(0.0, slack) / (a.mu[c] * -d));
      else if (slack < 0.0)
        t = 0.0;
    }
    if (!(t > 0.0)) continue;
    for (int i = 0; i < m; ++i)
      (*z)[s.members[i]] = std::max(0.0, b.p[i] + t * (b.target[i] - b.p[i]));
  }
}

}  // namespace vinci::sim::internal
