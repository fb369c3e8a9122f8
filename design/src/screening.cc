#include "vinci/design/screening.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "vinci/sim/formulations/contact.h"

namespace vinci::design {
namespace {

using Clock = std::chrono::steady_clock;

const char* TypeName(StageType t) { return t == StageType::kGeometric ? "geometric" : "short"; }

}  // namespace

// A short stage: the spec with the stage's horizon, samples, success set and simulator options,
// judged like a full evaluation.
struct Screener::ShortStage {
  explicit ShortStage(const DesignSpec& spec, const ScreeningStage& st, int threads)
      : stage_spec(std::make_unique<DesignSpec>(spec)) {
    stage_spec->screening.clear();
    stage_spec->duration = st.duration;
    stage_spec->samples = st.samples;
    stage_spec->objective = st.objective;
    stage_spec->scene.options = st.options;
    problem = std::make_unique<DesignProblem>(*stage_spec);
    evaluator = std::make_unique<ThreadEvaluator>(*problem, threads);
  }
  std::unique_ptr<DesignSpec> stage_spec;
  std::unique_ptr<DesignProblem> problem;
  std::unique_ptr<ThreadEvaluator> evaluator;
};

Screener::Screener(const DesignSpec& spec, const DesignProblem& problem, int threads)
    : spec_(&spec), problem_(&problem), threads_(std::max(1, threads)) {
  for (const ScreeningStage& st : spec.screening) {
    short_.push_back(st.type == StageType::kShort ? std::make_unique<ShortStage>(spec, st, threads_)
                                                  : nullptr);
    rows_.push_back(StageReport{TypeName(st.type)});
  }
  if (!rows_.empty()) rows_.push_back(StageReport{"full"});
}

Screener::~Screener() = default;

bool Screener::Overlaps(const VectorXd& x, std::uint64_t stream, const ScreeningStage& st) const {
  const std::shared_ptr<const sim::Simulator> simulator = problem_->SimulatorFor(x);
  std::vector<sim::Contact> contacts;
  for (int i = 0; i < std::max(1, st.samples); ++i) {
    sim::Params params = problem_->ParamsFor(x);
    sim::State state = simulator->InitialState();
    if (st.samples > 0) problem_->SampleStart(*simulator, x, stream, i, &params, &state);
    const sim::Scene scene = spec_->scene.ApplyParams(params);
    contacts.clear();
    sim::FindContacts(scene, sim::ComputeBodyKinematics(scene, state), 0.0, &contacts);
    for (const sim::Contact& c : contacts) {
      const double gap = c.point.corner ? std::max(c.point.gap, c.point.gap2) : c.point.gap;
      if (-gap > st.tolerance) return true;
    }
  }
  return false;
}

int Screener::Screen(const VectorXd& x, std::uint64_t stream) {
  for (std::size_t k = 0; k < spec_->screening.size(); ++k) {
    const ScreeningStage& st = spec_->screening[k];
    StageReport& row = rows_[k];
    const Clock::time_point start = Clock::now();
    bool pass = true;
    if (st.type == StageType::kGeometric) {
      pass = !Overlaps(x, stream, st);
    } else {
      const Evaluation e = short_[k]->evaluator->Evaluate({EvalRequest{x, stream, st.samples}})[0];
      row.simulations += st.samples;
      // successes / samples ≥ min_success, without rounding trouble at equality.
      pass = e.successes >= static_cast<int>(std::ceil(st.min_success * st.samples - 1e-9));
    }
    ++row.candidates_in;
    row.candidates_out += pass ? 1 : 0;
    row.time_s += std::chrono::duration<double>(Clock::now() - start).count();
    if (!pass) return static_cast<int>(k);
  }
  return -1;
}

Evaluation Screener::Rejected(const VectorXd& x, std::uint64_t stream, int samples, int k) const {
  Evaluation e;
  e.x = x;
  e.stream = stream;
  e.samples = samples;
  e.objective = 0.0;
  e.loss = 2.0 + static_cast<double>(static_cast<int>(spec_->screening.size()) - 1 - k);
  e.lower = e.upper = 0.0;  // not simulated: no interval
  return e;
}

void Screener::CountFull(int candidates, long long simulations, double time_s) {
  if (rows_.empty()) return;
  StageReport& row = rows_.back();
  row.candidates_in += candidates;
  row.candidates_out += candidates;
  row.simulations += simulations;
  row.time_s += time_s;
}

std::vector<StageReport> Screener::Report() const { return rows_; }

std::string Screener::Phase(int k) const {
  return std::string("screened-") + TypeName(spec_->screening[static_cast<std::size_t>(k)].type);
}

}  // namespace vinci::design
