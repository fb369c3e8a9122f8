// Batch evaluation on a thread pool: many rollouts of one Simulator, or any N independent tasks
// that each need a per-thread workspace (design objectives, planner propagations, estimator
// residuals).
//
// Contract shared by every function here:
//   - Task i's result lands in slot i (input order), whatever thread ran it.
//   - Each thread owns one workspace, created in that thread before its first task and reused by
//     its later tasks. A workspace is a cache only: a task's result must be a pure function of
//     the task index and the task's inputs (Simulator::Step with its Workspace is). Then results
//     are bit-identical for any thread count (tested for 1, 2 and 4 threads).
//   - Tasks start in index order. An exception thrown by a task is caught and recorded in that
//     task's result (status kError, what(), the exception_ptr); it never reaches std::terminate,
//     and every started thread is joined before the function returns or throws.
//   - progress(done, total) runs on the calling thread, never concurrently with itself, once per
//     finished task (ok or error): done = 1, 2, ... in order. If the callback throws, no further
//     task starts, the threads are joined, and the exception propagates to the caller.
//   - cancel: once *cancel is true no further task starts (status kCancelled); running tasks
//     finish (rollouts stop at their next step and return their partial trajectory). The flag may
//     be set from any thread, including inside progress.
//
// Example (100 friction values, 2 threads, only the final state kept):
//   std::vector<RolloutTask> tasks(100);
//   for (int i = 0; i < 100; ++i) {
//     Params p = sim.DefaultParams();
//     p.values[sim.scene().param_table().Index("mu.default")] = 0.1 + 0.005 * i;
//     tasks[i].params = p;
//     tasks[i].num_steps = 1000;
//   }
//   BatchRolloutOptions o;
//   o.threads = 2;
//   o.state_stride = 0;  // keep x0 and the last state
//   const std::vector<RolloutResult> r = BatchRollouts(sim, tasks, o);
//   // r[i].trajectory.states.back(): the final state of rollout i
#pragma once

#include <atomic>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {

/// How a batch runs (see the contract at the top of this file).
struct BatchOptions {
  /// Worker threads, ≥ 1 (capped at the task count). 1 runs every task on the calling thread;
  /// with more, the calling thread only waits and reports progress.
  int threads = 1;
  /// (tasks finished, total), on the calling thread. May be empty.
  std::function<void(int done, int total)> progress;
  /// Optional cancel flag, read before each task starts (and between rollout steps).
  const std::atomic<bool>* cancel = nullptr;
  /// true: after a task throws, no further task starts (the remaining ones are kCancelled). The
  /// lowest-index failing task is still found for any thread count, since tasks start in order.
  bool stop_on_error = false;
};

/// What happened to one task.
enum class TaskStatus {
  kOk,         ///< ran to completion (a rollout's own numerical failure is in its trajectory)
  kError,      ///< threw: see error / exception
  kCancelled,  ///< not started (cancel flag, or stop_on_error after another task threw), or a
               ///< rollout stopped early by the cancel flag
};

/// "ok", "error", "cancelled".
const char* TaskStatusName(TaskStatus s);

/// The per-task outcome of RunBatch.
struct TaskOutcome {
  TaskStatus status = TaskStatus::kCancelled;
  std::string error;             ///< what() of the exception (kError)
  std::exception_ptr exception;  ///< the exception itself (kError), for std::rethrow_exception
};

/// The thread count RunBatch uses for n tasks: min(options.threads, n), at least 1.
/// Throws std::invalid_argument if options.threads < 1.
int BatchThreadCount(const BatchOptions& options, int n);

/// The core: runs task(i, thread) for i in [0, n), thread ∈ [0, BatchThreadCount(options, n)) the
/// index of the worker running it (thread 0 is the calling thread when there is one worker).
/// Returns one outcome per task, in index order. Throws std::invalid_argument for n < 0 or
/// threads < 1, and rethrows an exception from options.progress (after joining).
std::vector<TaskOutcome> RunBatch(int n, const std::function<void(int task, int thread)>& task,
                                  const BatchOptions& options = {});

/// One task's result from BatchMap.
template <class R>
struct TaskResult : TaskOutcome {
  R value{};  ///< valid when status == kOk
};

/// Map over N tasks with a per-thread workspace:
///   results[i].value = fn(i, ws) for i in [0, n),
/// where ws (a W&) is the workspace of the thread running task i, made by make_workspace() in
/// that thread before its first task. R = the return type of fn, default-constructible.
template <class W, class Fn>
auto BatchMap(int n, const std::function<W()>& make_workspace, Fn fn,
              const BatchOptions& options = {})
    -> std::vector<TaskResult<std::decay_t<std::invoke_result_t<Fn&, int, W&>>>> {
  using R = std::decay_t<std::invoke_result_t<Fn&, int, W&>>;
  std::vector<TaskResult<R>> results(static_cast<std::size_t>(n < 0 ? 0 : n));
  std::vector<std::unique_ptr<W>> workspaces(
      static_cast<std::size_t>(BatchThreadCount(options, n)));
  const std::vector<TaskOutcome> outcomes = RunBatch(
      n,
      [&](int i, int thread) {
        std::unique_ptr<W>& ws = workspaces[static_cast<std::size_t>(thread)];
        if (!ws) ws = std::make_unique<W>(make_workspace());
        results[static_cast<std::size_t>(i)].value = fn(i, *ws);
      },
      options);
  for (std::size_t i = 0; i < results.size(); ++i)
    static_cast<TaskOutcome&>(results[i]) = outcomes[i];
  return results;
}

/// BatchMap with a default-constructed workspace per thread.
template <class W, class Fn>
auto BatchMap(int n, Fn fn, const BatchOptions& options = {}) {
  return BatchMap<W>(n, std::function<W()>([] { return W(); }), std::move(fn), options);
}

/// Rethrows the exception of the lowest-index task with status kError, if any.
template <class Outcomes>
void RethrowFirstError(const Outcomes& outcomes) {
  for (const auto& o : outcomes)
    if (o.status == TaskStatus::kError && o.exception) std::rethrow_exception(o.exception);
}

// ----- rollouts ---------------------------------------------------------------------------------

/// One rollout of a batch.
struct RolloutTask {
  std::optional<Params> params;   ///< unset: Simulator::DefaultParams()
  std::optional<State> x0;        ///< unset: Simulator::InitialState()
  std::vector<StepInput> inputs;  ///< one step per input; if empty, num_steps steps, no input
  int num_steps = 0;              ///< used only when inputs is empty (≥ 0)
};

/// BatchOptions plus what each rollout keeps, so that thousands of rollouts need not hold every
/// state in memory.
struct BatchRolloutOptions : BatchOptions {
  /// Kept states: x0, every state_stride-th state (step counts that are multiples of the
  /// stride) and always the last state reached. 1 keeps every state (the trajectory is then
  /// exactly Simulator::Rollout's); 0 keeps only x0 and the last state.
  int state_stride = 1;
  /// true: every StepInfo; false: only the failed step's, if a step failed.
  bool step_reports = true;
};

/// One rollout's result.
struct RolloutResult {
  TaskStatus status = TaskStatus::kCancelled;
  std::string error;             ///< what() of the exception (kError)
  std::exception_ptr exception;  ///< (kError)
  /// The kept states and step reports; ok / failure as Simulator::Rollout (a failed step stops
  /// the rollout and is recorded, not thrown). With state_stride 1 and step_reports true this is
  /// bit-identical to Simulator::Rollout(params, x0, inputs).
  Trajectory trajectory;
  /// state_steps[j]: the number of steps taken to reach trajectory.states[j] (0 for x0).
  std::vector<int> state_steps;
  int steps_done = 0;  ///< successful steps taken
};

/// Runs tasks[i] for every i (see the contract above), one Workspace per thread.
std::vector<RolloutResult> BatchRollouts(const Simulator& sim,
                                         const std::vector<RolloutTask>& tasks,
                                         const BatchRolloutOptions& options = {});

/// As above with the tasks made on demand, make_task(i) in the worker thread, so a large batch
/// never holds all its inputs at once. make_task must be thread-safe (e.g. const captures only).
std::vector<RolloutResult> BatchRollouts(const Simulator& sim, int n,
                                         const std::function<RolloutTask(int)>& make_task,
                                         const BatchRolloutOptions& options = {});

/// One rollout into *out with a caller-supplied workspace, honouring options' keep settings and
/// cancel flag (its threads and progress are unused). The building block of BatchRollouts, for
/// BatchMap tasks that run rollouts of their own. Throws what Simulator::Step throws.
void RunRollout(const Simulator& sim, const RolloutTask& task, const BatchRolloutOptions& options,
                Workspace* ws, RolloutResult* out);

}  // namespace vinci::sim
