// Least squares' cost of one multiple-shooting segment (least_squares.cc): a ceres::CostFunction
// whose residuals are the segment's measured samples and its continuity defect, with Jacobians
// from the step sensitivities or central differences of rollouts. Private to
// vinci::estimation.
#pragma once

#include <ceres/ceres.h>

#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "estimation_internal.h"
#include "least_squares_internal.h"
#include "segment_sensitivity.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/state_util.h"

namespace vinci::estimation::internal {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// One shooting segment: the samples of an episode from the segment's start state s_j (at its
// first sample) up to the next segment's first sample. Residuals: the logged samples of the
// segment (all of them for the episode's last segment, all but the next segment's first
// otherwise) and, if there is a next segment, the continuity defect
// c ⊙ (x(t_next; θ, s_j) − s_{j+1}) in the next segment's state coordinates. Parameter blocks:
// θ, then (if estimated) s_j, then (if there is a next segment) s_{j+1}. Jacobians for θ and
// s_j by forward step sensitivities along the rollout (segment_sensitivity.h) or central
// differences of rollouts (one-sided at a parameter bound); for s_{j+1} −c.
class SegmentCost : public ceres::CostFunction {
 public:
  SegmentCost(const sim::Simulator& sim, const sim::ParamSelection& sel, const sim::Params& base,
              Episode segment, int measured_samples, const sim::State& ref, bool with_state,
              const sim::VectorXd& fixed_state, std::unique_ptr<Episode> next,
              const sim::VectorXd& continuity_scale, const double* weight,
              const LeastSquaresOptions& opt, int index, OrderedLog* failures, JacobianStats* stats)
      : sim_(sim),
        sel_(sel),
        base_(base),
        ep_(std::move(segment)),
        ref_(ref),
        with_state_(with_state),
        fixed_state_(fixed_state),
        next_(std::move(next)),
        scale_(continuity_scale),
        weight_(weight),
        opt_(opt),
        index_(index),
        failures_(failures),
        stats_(stats) {
    measured_rows_ = measured_samples * ResidualsPerSample(ep_, sim.scene().dim);
    continuity_rows_ = next_ ? static_cast<int>(scale_.size()) : 0;
    set_num_residuals(measured_rows_ + continuity_rows_);
    mutable_parameter_block_sizes()->push_back(sel.size());
    if (with_state)
      mutable_parameter_block_sizes()->push_back(static_cast<int>(fixed_state.size()));
    if (next_) mutable_parameter_block_sizes()->push_back(continuity_rows_);
  }

  int measured_rows() const { return measured_rows_; }

  /// The Jacobians of this segment at (θ, s, s_next) (s_next ignored without a next segment),
  /// split into the measured rows and the rollout's end state (the continuity rows divided by
  /// w c). False if a rollout failed.
  bool Jacobians(const sim::VectorXd& theta, const sim::VectorXd& s, const double* s_next,
                 SegmentDerivatives* out, sim::VectorXd* residuals = nullptr) const {
    const int m = num_residuals(), np = sel_.size(), ns = static_cast<int>(fixed_state_.size());
    RowMajor j_theta(m, np), j_state(m, ns), j_next(m, std::max(1, continuity_rows_));
    std::vector<const double*> params = {theta.data()};
    std::vector<double*> jac = {j_theta.data()};
    if (with_state_) {
      params.push_back(s.data());
      jac.push_back(j_state.data());
    }
    if (next_) {
      params.push_back(s_next);
      jac.push_back(j_next.data());
    }
    sim::VectorXd r(m);
    if (!Evaluate(params.data(), r.data(), jac.data())) return false;
    if (residuals) *residuals = r;
    out->measured_theta = j_theta.topRows(measured_rows_);
    out->measured_state = with_state_ ? sim::MatrixXd(j_state.topRows(measured_rows_))
                                      : sim::MatrixXd::Zero(measured_rows_, ns);
    if (next_) {
      const sim::VectorXd inv = (*weight_ * scale_).cwiseInverse();
      out->end_theta = inv.asDiagonal() * j_theta.bottomRows(continuity_rows_);
      out->end_state = inv.asDiagonal() * j_state.bottomRows(continuity_rows_);
    }
    return true;
  }
  int continuity_rows() const { return continuity_rows_; }
  /// Threads for the finite-difference columns of one evaluation (when the problem has fewer
  /// segments than threads); the columns are the same for any count.
  void set_column_threads(int threads) { column_threads_ = std::max(1, threads); }
  const Episode& segment() const { return ep_; }
  const sim::State& ref() const { return ref_; }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    try {
      return EvaluateOrThrow(parameters, residuals, jacobians);
    } catch (const std::exception& e) {
      failures_->Record(index_, ep_.file + ": " + e.what());
      return false;
    }
  }

 private:
  // The residuals at (θ, s, s_next). A failed rollout is recorded in failures_, or, with
  // `failure_out` given, described there instead.
  bool Residuals(const sim::VectorXd& theta, const sim::VectorXd& s, const double* s_next,
                 sim::VectorXd* r, std::string* failure_out = nullptr) const {
    const sim::Params p = sel_.Set(base_, theta);
    const sim::State x0 = StateFromVector(sim_, ep_, ref_, s.data());
    std::string failure;
    sim::VectorXd measured;
    sim::Trajectory tr;
    if (!RolloutResiduals(sim_, p, ep_, x0, opt_.orientation_length, &measured, &failure,
                          next_ ? &tr : nullptr)) {
      const std::string what =
          ep_.file + " (t = " + std::to_string(ep_.t.front()) + "): " + failure;
      if (failure_out)
        *failure_out = what;
      else
        failures_->Record(index_, what);
      return false;
    }
    r->resize(num_residuals());
    r->head(measured_rows_) = measured.head(measured_rows_);
    if (next_) {
      const sim::VectorXd end = VectorAt(sim_, *next_, tr, next_->t.front());
      r->tail(continuity_rows_) =
          *weight_ *
          scale_.cwiseProduct(end - Eigen::Map<const sim::VectorXd>(s_next, continuity_rows_));
    }
    return true;
  }

  bool EvaluateOrThrow(double const* const* parameters, double* residuals,
                       double** jacobians) const {
    const int np = sel_.size();
    sim::VectorXd theta = Eigen::Map<const sim::VectorXd>(parameters[0], np);
    sim::VectorXd s =
        with_state_
            ? sim::VectorXd(Eigen::Map<const sim::VectorXd>(parameters[1], fixed_state_.size()))
            : fixed_state_;
    const int next_block = with_state_ ? 2 : 1;
    const double* s_next = next_ ? parameters[next_block] : nullptr;
    const int m = num_residuals();
    const bool want_state = with_state_ && jacobians && jacobians[1];
    if (jacobians && (jacobians[0] || want_state) && stats_->active()) {
      // Residuals and Jacobians from one rollout with forward step sensitivities.
      SegmentSensitivityResult sr;
      try {
        sr = SegmentSensitivity(sim_, sel_, sel_.Set(base_, theta), ep_, ref_, s, want_state,
                                measured_rows_, next_.get(), opt_.orientation_length);
      } catch (const std::invalid_argument& e) {
        stats_->Unsupported(index_, e.what());  // no step sensitivities here: finite differences
        sr.status = SegmentSensitivityStatus::kSensitivityFailed;
        sr.failure.clear();
      }
      if (sr.status == SegmentSensitivityStatus::kRolloutFailed && !sr.failure.empty()) {
        failures_->Record(index_,
                          ep_.file + " (t = " + std::to_string(ep_.t.front()) + "): " + sr.failure);
        return false;
      }
      if (sr.status == SegmentSensitivityStatus::kOk) {
        stats_->Count(sr.degenerate_steps, sr.mode_change_steps);
        Eigen::Map<sim::VectorXd> r(residuals, m);
        r.head(measured_rows_) = sr.measured;
        sim::VectorXd c;
        if (next_) {
          c = *weight_ * scale_;
          r.tail(continuity_rows_) =
              c.cwiseProduct(sr.end - Eigen::Map<const sim::VectorXd>(s_next, continuity_rows_));
          if (jacobians[next_block]) {
            Eigen::Map<RowMajor> J(jacobians[next_block], m, continuity_rows_);
            J.setZero();
            J.bottomRows(continuity_rows_).diagonal() = -c;
          }
        }
        for (int block = 0; block < (with_state_ ? 2 : 1); ++block) {
          if (!jacobians[block]) continue;
          const int first = block == 0 ? 0 : np;
          const int n = block == 0 ? np : static_cast<int>(s.size());
          Eigen::Map<RowMajor> J(jacobians[block], m, n);
          J.topRows(measured_rows_) = sr.d_measured.middleCols(first, n);
          if (next_)
            J.bottomRows(continuity_rows_) = c.asDiagonal() * sr.d_end.middleCols(first, n);
        }
        return true;
      }
      if (!sr.failure.empty()) stats_->Fallback(index_, ep_.file + ": " + sr.failure);
    }
    sim::VectorXd r;
    if (!Residuals(theta, s, s_next, &r)) return false;
    Eigen::Map<sim::VectorXd>(residuals, m) = r;
    if (!jacobians) return true;
    if (next_ && jacobians[next_block]) {
      Eigen::Map<RowMajor> J(jacobians[next_block], m, continuity_rows_);
      J.setZero();
      J.bottomRows(continuity_rows_).diagonal() = -*weight_ * scale_;
    }
    // Central differences, column by column (on column_threads_ threads, each column from its
    // own copy of (θ, s)); a failed rollout is recorded for the lowest failing column.
    const sim::VectorXd lo = sel_.lower(), hi = sel_.upper();
    std::vector<std::pair<int, int>> columns;  // (block, index)
    for (int block = 0; block < (with_state_ ? 2 : 1); ++block)
      if (jacobians[block])
        for (int j = 0; j < (block == 0 ? np : static_cast<int>(s.size())); ++j)
          columns.emplace_back(block, j);
    const int nc = static_cast<int>(columns.size());
    std::vector<std::string> failed(nc);
    std::vector<char> ok(nc, 1);
    const auto column = [&](int c) {
      const auto [block, j] = columns[c];
      sim::VectorXd th = theta, st = s;
      sim::VectorXd& x = block == 0 ? th : st;
      const double xj = x[j];
      const double h = opt_.fd_relative_step * std::max(1.0, std::abs(xj));
      const bool down_ok = block != 0 || xj - h >= lo[j];
      const bool up_ok = block != 0 || xj + h <= hi[j];
      sim::VectorXd rp = r, rm = r;
      double width = 0.0;
      if (up_ok) {
        x[j] = xj + h;
        if (!Residuals(th, st, s_next, &rp, &failed[c])) return false;
        width += h;
      }
      if (down_ok) {
        x[j] = xj - h;
        if (!Residuals(th, st, s_next, &rm, &failed[c])) return false;
        width += h;
      }
      if (width == 0.0) return false;
      Eigen::Map<RowMajor> J(jacobians[block], m, block == 0 ? np : static_cast<int>(s.size()));
      J.col(j) = (rp - rm) / width;
      return true;
    };
    ParallelFor(nc, column_threads_, [&](int c) { ok[c] = column(c); });
    for (int c = 0; c < nc; ++c) {
      if (ok[c]) continue;
      if (!failed[c].empty()) failures_->Record(index_, failed[c]);
      return false;
    }
    return true;
  }

  const sim::Simulator& sim_;
  const sim::ParamSelection& sel_;
  const sim::Params& base_;
  const Episode ep_;
  const sim::State ref_;
  const bool with_state_;
  const sim::VectorXd fixed_state_;
  const std::unique_ptr<Episode> next_;
  const sim::VectorXd scale_;
  const double* weight_;  // the continuity weight w of the current stage
  const LeastSquaresOptions& opt_;
  const int index_;  // the segment's position in the problem (orders OrderedLog entries)
  OrderedLog* failures_;
  JacobianStats* stats_;
  int measured_rows_ = 0, continuity_rows_ = 0;
  int column_threads_ = 1;
};

}  // namespace vinci::estimation::internal
