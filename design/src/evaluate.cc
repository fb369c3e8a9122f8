#include "vinci/design/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <iterator>
#include <stdexcept>

#include "vinci/design/grip.h"
#include "vinci/sim/simulator/batch.h"

namespace vinci::design {
namespace {

constexpr double kZ95 = 1.959963984540054;
constexpr double kPi = 3.14159265358979323846;

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// xoshiro256** seeded by SplitMix64: a small generator whose output is the same on every
// platform (std distributions are implementation-defined, so they are not used).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) {
    for (auto& w : s_) w = seed = SplitMix64(seed);
  }
  std::uint64_t Next() {
    const std::uint64_t result = Rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }
  /// Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  /// Standard normal (Box–Muller, one value per call).
  double Normal() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  static std::uint64_t Rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
};

double Draw(const Uncertain& u, Rng* rng) {
  switch (u.type) {
    case DistributionType::kUniform:
      return u.a + (u.b - u.a) * rng->Uniform();
    case DistributionType::kChoice: {
      const std::size_t k = static_cast<std::size_t>(rng->Uniform() * u.choices.size());
      return u.choices[std::min(k, u.choices.size() - 1)];
    }
    case DistributionType::kNormal:
      break;
  }
  if (!u.truncated) return u.a + u.b * rng->Normal();
  // Redraw until inside [lo, hi] (the loader bounds the interval within 5 std of the mean, so
  // the acceptance probability is > 1e-7; the clamp after the limit is a formality).
  for (int k = 0; k < 100000; ++k) {
    const double v = u.a + u.b * rng->Normal();
    if (v >= u.lo && v <= u.hi) return v;
  }
  return std::min(std::max(u.a, u.lo), u.hi);
}

// Angle error wrapped to (−π, π], or to (−s/2, s/2] modulo a symmetry s.
double AngleError(const Objective& o, double theta) {
  const double period = o.angle_symmetry > 0.0 ? o.angle_symmetry : 2.0 * kPi;
  return std::remainder(theta - o.angle_target, period);
}

// Signed distance of p to the box [lo, hi] (negative inside).
double BoxSignedDistance(const VectorXd& p, const VectorXd& lo, const VectorXd& hi) {
  double outside = 0.0, inside = -1e300;
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    const double q = std::max(lo[k] - p[k], p[k] - hi[k]);
    outside += q > 0.0 ? q * q : 0.0;
    inside = std::max(inside, q);
  }
  return outside > 0.0 ? std::sqrt(outside) : inside;
}

}  // namespace

void WilsonInterval(int k, int n, double* lower, double* upper) {
  if (n <= 0) {
    *lower = 0.0;
    *upper = 1.0;
    return;
  }
  const double p = static_cast<double>(k) / n, z2 = kZ95 * kZ95;
  const double denom = 1.0 + z2 / n;
  const double centre = (p + z2 / (2.0 * n)) / denom;
  const double half = kZ95 * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / denom;
  *lower = std::max(0.0, centre - half);
  *upper = std::min(1.0, centre + half);
}

std::uint64_t SampleSeed(std::uint64_t stream, int i) {
  return SplitMix64(SplitMix64(stream) ^ static_cast<std::uint64_t>(i));
}

std::uint64_t FreshStream(std::uint64_t seed) { return SplitMix64(seed ^ 0x6672657368ULL); }

DesignProblem::DesignProblem(const DesignSpec& spec)
    : spec_(&spec), base_(std::make_shared<const sim::Simulator>(spec.scene)) {}

VectorXd DesignProblem::lower() const {
  VectorXd v(size());
  for (int k = 0; k < size(); ++k) v[k] = spec_->parameters[k].lower;
  return v;
}

VectorXd DesignProblem::upper() const {
  VectorXd v(size());
  for (int k = 0; k < size(); ++k) v[k] = spec_->parameters[k].upper;
  return v;
}

VectorXd DesignProblem::start() const {
  VectorXd v(size());
  for (int k = 0; k < size(); ++k) v[k] = spec_->parameters[k].start;
  return v;
}

sim::Params DesignProblem::ParamsFor(const VectorXd& x) const {
  sim::Params params = spec_->scene.DefaultParams();
  for (int k = 0; k < size(); ++k) params.values[spec_->parameters[k].target.index] = x[k];
  return params;
}

sim::Scene DesignProblem::SceneFor(const VectorXd& x) const {
  return spec_->scene.ApplyParams(ParamsFor(x));
}

std::shared_ptr<const sim::Simulator> DesignProblem::SimulatorFor(const VectorXd&) const {
  return base_;
}

void DesignProblem::SampleStart(const sim::Simulator& simulator, const VectorXd& x,
                                std::uint64_t stream, int i, sim::Params* params,
                                sim::State* state) const {
  const sim::Scene& scene = simulator.scene();
  const bool planar = scene.dim == sim::Dim::kPlanar;
  *params = ParamsFor(x);
  *state = simulator.InitialState();
  Rng rng(SampleSeed(stream, i));
  for (const Uncertain& u : spec_->uncertain) {
    const double v = Draw(u, &rng);
    if (u.target.kind == TargetKind::kParam) {
      params->values[u.target.index] = v;
    } else {
      const sim::BodyIndex& bi = scene.index(u.target.body);
      if (u.target.velocity) {
        state->v[bi.v + u.target.coord] = v;
      } else if (planar || u.target.coord < 3) {
        state->q[bi.q + u.target.coord] = v;
      }
    }
  }
}

SampleOutcome DesignProblem::RunSample(const sim::Simulator& simulator, const VectorXd& x,
                                       std::uint64_t stream, int i, sim::Workspace* ws) const {
  const DesignSpec& spec = *spec_;
  const sim::Scene& scene = simulator.scene();
  const bool planar = scene.dim == sim::Dim::kPlanar;
  sim::Params params;
  sim::State state;
  SampleStart(simulator, x, stream, i, &params, &state);

  const Objective& o = spec.objective;
  const int iq = scene.index(o.body_index).q;
  const int np = planar ? 2 : 3;
  VectorXd p(np);
  // The per-state value: margin (success: inside iff margin ≤ 0 and the parts agree).
  const auto judge = [&](const sim::State& s, bool* inside) {
    for (int k = 0; k < np; ++k) p[k] = s.q[iq + k];
    if (o.type == ObjectiveType::kDistance) {
      *inside = false;
      return (p - o.target).norm();
    }
    bool in = true;
    double margin = -1e300;
    if (o.has_region) {
      const double sd = BoxSignedDistance(p, o.region_min, o.region_max);
      in = in && sd <= 0.0;
      margin = std::max(margin, sd);
    }
    if (o.has_angle) {
      const double e = std::abs(AngleError(o, s.q[iq + 2])) - o.angle_tolerance;
      in = in && e <= 0.0;
      margin = std::max(margin, o.angle_scale * e);
    }
    if (o.has_grip)
      in = in && IsGripped(o.grip, JawOverlaps(simulator.Resolve(params, ws), s, o.body_index,
                                               o.grip.jaw_indices));
    *inside = in;
    return margin;
  };

  SampleOutcome out;
  const int steps = std::max(1, static_cast<int>(std::lround(spec.duration / scene.options.dt)));
  const sim::StepInput input;
  sim::State next;
  bool inside = false;
  double value = judge(state, &inside);
  double best = value;
  bool reached = o.until && inside;
  for (int k = 0; k < steps && !reached; ++k) {
    const sim::StepInfo info = simulator.Step(params, state, input, ws, &next);
    if (!info.ok) {
      out.ok = false;
      out.failure =
          "step " + std::to_string(k) + " (t = " + std::to_string(state.t) + " s): " + info.failure;
      break;
    }
    std::swap(state, next);
    if (o.until) {
      value = judge(state, &inside);
      best = std::min(best, value);
      reached = inside;
    }
  }
  if (!o.until) {
    value = judge(state, &inside);
    best = value;
  }
  switch (o.type) {
    case ObjectiveType::kDistance:
      out.value = value;
      break;
    case ObjectiveType::kSuccess:
      out.success = out.ok && (o.until ? reached : inside);
      // The margin, for ranking designs of equal success rate (a failed sample is not inside).
      out.value = out.ok ? best : std::max(best, 0.0);
      break;
    case ObjectiveType::kMargin:
      out.success = out.ok && (o.until ? reached : inside);
      out.value = best;
      break;
  }
  return out;
}

Evaluation DesignProblem::Summarize(const VectorXd& x, std::uint64_t stream,
                                    const std::vector<SampleOutcome>& outcomes,
                                    double time_s) const {
  Evaluation e;
  e.x = x;
  e.stream = stream;
  e.samples = static_cast<int>(outcomes.size());
  e.time_s = time_s;
  double sum = 0.0;
  for (const SampleOutcome& s : outcomes) {
    e.successes += s.success ? 1 : 0;
    if (!s.ok) {
      if (e.failures == 0) e.first_failure = s.failure;
      ++e.failures;
    }
    sum += s.value;
  }
  WilsonInterval(e.successes, e.samples, &e.lower, &e.upper);
  const double mean = e.samples > 0 ? sum / e.samples : 0.0;
  if (spec_->objective.type == ObjectiveType::kSuccess) {
    e.objective = e.samples > 0 ? static_cast<double>(e.successes) / e.samples : 0.0;
    e.loss = 1.0 - e.objective;
    // Ties on the rate are broken by the mean margin: + T(m̄)/S with T increasing in (0, 1),
    // so the term never reorders different success counts (they differ by ≥ 1/S).
    if (e.samples > 0) {
      const double s = spec_->objective.angle_scale;
      const double t = 0.5 * (1.0 + mean / (std::abs(mean) + s));
      e.loss += std::min(std::max(t, 0.0), 1.0 - 1e-9) / e.samples;
    }
  } else {
    e.objective = mean;
    e.loss = mean;
  }
  return e;
}

std::vector<SampleOutcome> RunSampleTasks(
    const DesignProblem& problem, const std::vector<EvalRequest>& requests,
    const std::vector<std::shared_ptr<const sim::Simulator>>& sims,
    const std::vector<SampleTask>& tasks, int threads) {
  // One sim::Workspace per thread (sim/simulator/batch.h), reset when the thread moves on to
  // another design's Simulator (a workspace caches the resolved scene of one simulator).
  struct ThreadWorkspace {
    sim::Workspace ws;
    const sim::Simulator* last = nullptr;
  };
  sim::BatchOptions options;
  options.threads = std::max(1, threads);
  options.stop_on_error = true;
  auto results = sim::BatchMap<ThreadWorkspace>(
      static_cast<int>(tasks.size()),
      [&](int k, ThreadWorkspace& tw) {
        const SampleTask& t = tasks[static_cast<std::size_t>(k)];
        const EvalRequest& q = requests.at(static_cast<std::size_t>(t.request));
        const sim::Simulator* s = sims.at(static_cast<std::size_t>(t.request)).get();
        if (s != tw.last) tw.ws = sim::Workspace{};
        tw.last = s;
        return problem.RunSample(*s, q.x, q.stream, t.sample, &tw.ws);
      },
      options);
  sim::RethrowFirstError(results);  // the lowest-index failure, as a single thread would report it
  std::vector<SampleOutcome> out;
  out.reserve(results.size());
  for (auto& r : results) out.push_back(std::move(r.value));
  return out;
}

ThreadEvaluator::ThreadEvaluator(const DesignProblem& problem, int threads)
    : problem_(&problem), threads_(std::max(1, threads)) {}

std::vector<Evaluation> ThreadEvaluator::Evaluate(const std::vector<EvalRequest>& requests) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  std::vector<SampleTask> tasks;
  std::vector<std::shared_ptr<const sim::Simulator>> sims;
  for (std::size_t r = 0; r < requests.size(); ++r) {
    if (requests[r].x.size() != problem_->size())
      throw std::invalid_argument("ThreadEvaluator: design vector of size " +
                                  std::to_string(requests[r].x.size()) + ", expected " +
                                  std::to_string(problem_->size()));
    if (requests[r].samples < 0)
      throw std::invalid_argument("ThreadEvaluator: samples must be >= 0, got " +
                                  std::to_string(requests[r].samples));
    sims.push_back(problem_->SimulatorFor(requests[r].x));
    for (int i = 0; i < requests[r].samples; ++i) tasks.push_back({static_cast<int>(r), i});
  }
  std::vector<SampleOutcome> outcomes = RunSampleTasks(*problem_, requests, sims, tasks, threads_);
  const double per = std::chrono::duration<double>(Clock::now() - start).count() /
                     std::max<std::size_t>(1, requests.size());
  std::vector<Evaluation> result;
  result.reserve(requests.size());
  auto next = outcomes.begin();  // tasks are in request order, samples 0, 1, ... within each
  for (const EvalRequest& r : requests) {
    const std::vector<SampleOutcome> mine(std::make_move_iterator(next),
                                          std::make_move_iterator(next + r.samples));
    next += r.samples;
    result.push_back(problem_->Summarize(r.x, r.stream, mine, per));
  }
  return result;
}

}  // namespace vinci::design
