// One smooth NLP of the MPEC's sequence (mpec.cc): the problem plus a stage's treatment of the
// complementarity pairs, as Ipopt's TNLP.
#pragma once

#include <IpTNLP.hpp>
#include <algorithm>
#include <utility>
#include <vector>

#include "vinci/estimation/mpec.h"

namespace vinci::estimation::mpec_internal {

using Ipopt::Index;
using Ipopt::Number;
using sim::VectorXd;

constexpr double kInf = 1e19;

enum class Stage { kScholtes, kPenalty, kPolish };

// One smooth NLP of the sequence: the problem plus the stage's treatment of the pairs.
class RelaxedNlp : public Ipopt::TNLP {
 public:
  RelaxedNlp(const MpecProblem& p, const std::vector<std::pair<int, int>>& pairs, Stage stage,
             double param, const std::vector<bool>& first_at_zero, bool hessian,
             bool relaxation_curvature, const VectorXd& x0, const VectorXd* lambda0,
             const VectorXd* zl0, const VectorXd* zu0)
      : p_(p),
        pairs_(pairs),
        stage_(stage),
        param_(param),
        first_at_zero_(first_at_zero),
        hessian_(hessian),
        relaxation_curvature_(relaxation_curvature),
        x0_(x0),
        lambda0_(lambda0),
        zl0_(zl0),
        zu0_(zu0) {
    n_ = p.num_variables();
    m_ = p.num_constraints();
    jac_ = p.JacobianStructure();
    if (hessian_) hess_ = p.HessianStructure();
  }

  int extra_rows() const {
    return stage_ == Stage::kScholtes ? static_cast<int>(pairs_.size()) : 0;
  }

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = n_;
    m = m_ + extra_rows();
    nnz_jac = static_cast<Index>(jac_.size()) + 2 * extra_rows();
    nnz_h = hessian_ ? static_cast<Index>(hess_.size() + pairs_.size()) : 0;
    style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index n, Number* x_l, Number* x_u, Index m, Number* g_l,
                       Number* g_u) override {
    VectorXd xl, xu, gl, gu;
    p_.Bounds(&xl, &xu, &gl, &gu);
    for (int i = 0; i < n; ++i) {
      x_l[i] = std::max(xl[i], -kInf);
      x_u[i] = std::min(xu[i], kInf);
    }
    for (std::size_t k = 0; k < pairs_.size(); ++k) {
      x_l[pairs_[k].first] = std::max(x_l[pairs_[k].first], 0.0);
      x_l[pairs_[k].second] = std::max(x_l[pairs_[k].second], 0.0);
    }
    if (stage_ == Stage::kPolish) {
      for (std::size_t k = 0; k < pairs_.size(); ++k) {
        const int i = first_at_zero_[k] ? pairs_[k].first : pairs_[k].second;
        x_l[i] = 0.0;
        x_u[i] = 0.0;
      }
    }
    for (int j = 0; j < m_; ++j) {
      g_l[j] = std::max(gl[j], -kInf);
      g_u[j] = std::min(gu[j], kInf);
    }
    for (int k = m_; k < m; ++k) {
      g_l[k] = -kInf;
      g_u[k] = relaxation_scale_ * param_;
    }
    return true;
  }

  bool get_starting_point(Index n, bool init_x, Number* x, bool init_z, Number* z_L, Number* z_U,
                          Index m, bool init_lambda, Number* lambda) override {
    if (init_x) {
      for (int i = 0; i < n; ++i) x[i] = x0_[i];
    }
    if (init_z) {
      for (int i = 0; i < n; ++i) {
        z_L[i] = zl0_ ? (*zl0_)[i] : 1.0;
        z_U[i] = zu0_ ? (*zu0_)[i] : 1.0;
      }
    }
    if (init_lambda) {
      for (int j = 0; j < m; ++j) {
        lambda[j] = lambda0_ && j < lambda0_->size() ? (*lambda0_)[j] : 0.0;
        if (j >= m_) lambda[j] /= relaxation_scale_;
      }
    }
    return true;
  }

  bool eval_f(Index n, const Number* x, bool /*new_x*/, Number& f) override {
    const Eigen::Map<const VectorXd> xv(x, n);
    xbuf_ = xv;
    if (!p_.Objective(xbuf_, &f)) return false;
    if (stage_ == Stage::kPenalty) {
      for (const auto& [a, b] : pairs_) f += param_ * x[a] * x[b];
    }
    return std::isfinite(f);
  }

  bool eval_grad_f(Index n, const Number* x, bool /*new_x*/, Number* grad) override {
    xbuf_ = Eigen::Map<const VectorXd>(x, n);
    VectorXd g(n);
    if (!p_.Gradient(xbuf_, &g)) return false;
    if (stage_ == Stage::kPenalty) {
      for (const auto& [a, b] : pairs_) {
        g[a] += param_ * x[b];
        g[b] += param_ * x[a];
      }
    }
    for (int i = 0; i < n; ++i) grad[i] = g[i];
    return true;
  }

  bool eval_g(Index n, const Number* x, bool /*new_x*/, Index /*m*/, Number* g) override {
    xbuf_ = Eigen::Map<const VectorXd>(x, n);
    VectorXd gv(m_);
    if (!p_.Constraints(xbuf_, &gv)) return false;
    for (int j = 0; j < m_; ++j) g[j] = gv[j];
    for (int k = 0; k < extra_rows(); ++k)
      g[m_ + k] = relaxation_scale_ * x[pairs_[k].first] * x[pairs_[k].second];
    return true;
  }

  bool eval_jac_g(Index n, const Number* x, bool /*new_x*/, Index /*m*/, Index nele, Index* rows,
                  Index* cols, Number* values) override {
    const int nj = static_cast<int>(jac_.size());
    if (values == nullptr) {
      for (int e = 0; e < nj; ++e) {
        rows[e] = jac_[e].row;
        cols[e] = jac_[e].col;
      }
      for (int k = 0; k < extra_rows(); ++k) {
        rows[nj + 2 * k] = m_ + k;
        cols[nj + 2 * k] = pairs_[k].first;
        rows[nj + 2 * k + 1] = m_ + k;
        cols[nj + 2 * k + 1] = pairs_[k].second;
      }
      return true;
    }
    xbuf_ = Eigen::Map<const VectorXd>(x, n);
    VectorXd v(nj);
    if (!p_.JacobianValues(xbuf_, &v)) return false;
    for (int e = 0; e < nj; ++e) values[e] = v[e];
    for (int k = 0; k < extra_rows(); ++k) {
      values[nj + 2 * k] = relaxation_scale_ * x[pairs_[k].second];
      values[nj + 2 * k + 1] = relaxation_scale_ * x[pairs_[k].first];
    }
    (void)nele;
    return true;
  }

  bool eval_h(Index n, const Number* x, bool /*new_x*/, Number obj_factor, Index /*m*/,
              const Number* lambda, bool /*new_lambda*/, Index /*nele*/, Index* rows, Index* cols,
              Number* values) override {
    if (!hessian_) return false;
    const int nh = static_cast<int>(hess_.size());
    if (values == nullptr) {
      for (int e = 0; e < nh; ++e) {
        rows[e] = hess_[e].row;
        cols[e] = hess_[e].col;
      }
      for (std::size_t k = 0; k < pairs_.size(); ++k) {
        rows[nh + k] = std::max(pairs_[k].first, pairs_[k].second);
        cols[nh + k] = std::min(pairs_[k].first, pairs_[k].second);
      }
      return true;
    }
    xbuf_ = Eigen::Map<const VectorXd>(x, n);
    const VectorXd lam = Eigen::Map<const VectorXd>(lambda, m_);
    VectorXd v(nh);
    if (!p_.HessianValues(xbuf_, obj_factor, lam, &v)) return false;
    for (int e = 0; e < nh; ++e) values[e] = v[e];
    for (std::size_t k = 0; k < pairs_.size(); ++k) {
      double h = 0.0;
      if (stage_ == Stage::kScholtes && relaxation_curvature_)
        h = relaxation_scale_ * lambda[m_ + k];
      if (stage_ == Stage::kPenalty) h = obj_factor * param_;
      values[nh + k] = h;
    }
    return true;
  }

  // Records the iteration count; with a stall window (> 0) stops the NLP (Ipopt's "user
  // requested stop", stalled_ set) once the best error max(inf_pr, inf_du) over the last
  // `stall_window_` iterations is not below stall_reduction_ times the best before them.
  bool intermediate_callback(Ipopt::AlgorithmMode, Index iter, Number, Number inf_pr, Number inf_du,
                             Number, Number, Number, Number, Number, Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    iterations_ = iter;
    if (stall_window_ <= 0) return true;
    const double err = std::max(inf_pr, inf_du);
    errors_.push_back(std::isfinite(err) ? err : std::numeric_limits<double>::max());
    const int k = static_cast<int>(errors_.size());
    if (k <= stall_window_) return true;
    const double before = *std::min_element(errors_.begin(), errors_.end() - stall_window_);
    const double recent = *std::min_element(errors_.end() - stall_window_, errors_.end());
    if (recent > stall_reduction_ * before) {
      stalled_ = true;
      stall_error_ = recent;
      return false;
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn status, Index n, const Number* x, const Number* z_L,
                         const Number* z_U, Index /*m*/, const Number* /*g*/, const Number* lambda,
                         Number obj_value, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    status_ = status;
    x_ = Eigen::Map<const VectorXd>(x, n);
    z_l_ = Eigen::Map<const VectorXd>(z_L, n);
    z_u_ = Eigen::Map<const VectorXd>(z_U, n);
    lambda_ = Eigen::Map<const VectorXd>(lambda, m_ + extra_rows());
    lambda_.tail(extra_rows()) *= relaxation_scale_;  // the rows' multipliers as unscaled
    objective_ = obj_value;
  }

  Ipopt::SolverReturn status_ = Ipopt::INTERNAL_ERROR;
  VectorXd x_, z_l_, z_u_, lambda_;
  double objective_ = 0.0;
  int iterations_ = 0;
  // Scholtes: the relaxation rows written s x_a x_b ≤ s ε (multipliers in and out as for s = 1).
  // Ipopt meets a row to its tolerance (1e-8) in the row's own units: below ε ~ 1e-8 the
  // unscaled rows do not bind (products ~1e-8 pass as feasible), s = 1/ε makes them relative.
  double relaxation_scale_ = 1.0;
  int stall_window_ = 0;          // > 0: the stall exit of intermediate_callback
  double stall_reduction_ = 0.1;  // required reduction of the error over the window
  bool stalled_ = false;
  double stall_error_ = 0.0;  // the best error of the last window when stalled

 private:
  std::vector<double> errors_;
  const MpecProblem& p_;
  const std::vector<std::pair<int, int>>& pairs_;
  Stage stage_;
  double param_;
  std::vector<bool> first_at_zero_;
  bool hessian_;
  bool relaxation_curvature_;
  VectorXd x0_;
  const VectorXd *lambda0_, *zl0_, *zu0_;
  int n_ = 0, m_ = 0;
  std::vector<Entry> jac_, hess_;
  VectorXd xbuf_;
};

}  // namespace vinci::estimation::mpec_internal
