#include "vinci/sim/simulator/batch.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace vinci::sim {

const char* TaskStatusName(TaskStatus s) {
  switch (s) {
    case TaskStatus::kOk:
      return "ok";
    case TaskStatus::kError:
      return "error";
    case TaskStatus::kCancelled:
      return "cancelled";
  }
  return "?";
}

int BatchThreadCount(const BatchOptions& options, int n) {
  if (options.threads < 1)
    throw std::invalid_argument("batch: threads must be >= 1, got " +
                                std::to_string(options.threads));
  return std::max(1, std::min(options.threads, n));
}

namespace {

bool Cancelled(const BatchOptions& o) {
  return o.cancel && o.cancel->load(std::memory_order_relaxed);
}

// Runs task i, recording its outcome; never throws.
void RunOne(const std::function<void(int, int)>& task, int i, int thread, TaskOutcome* out) {
  try {
    task(i, thread);
    out->status = TaskStatus::kOk;
  } catch (const std::exception& e) {
    out->status = TaskStatus::kError;
    out->error = e.what();
    out->exception = std::current_exception();
  } catch (...) {
    out->status = TaskStatus::kError;
    out->error = "unknown exception";
    out->exception = std::current_exception();
  }
}

}  // namespace

std::vector<TaskOutcome> RunBatch(int n, const std::function<void(int task, int thread)>& task,
                                  const BatchOptions& options) {
  if (n < 0)
    throw std::invalid_argument("batch: task count must be >= 0, got " + std::to_string(n));
  const int threads = BatchThreadCount(options, n);
  std::vector<TaskOutcome> out(static_cast<std::size_t>(n));
  if (n == 0) return out;

  if (threads == 1) {
    for (int i = 0; i < n; ++i) {
      if (Cancelled(options)) break;
      RunOne(task, i, 0, &out[i]);
      if (options.progress) options.progress(i + 1, n);
      if (options.stop_on_error && out[i].status == TaskStatus::kError) break;
    }
    return out;
  }

  // Workers take the next index under the mutex (tasks start in index order, each worker takes
  // the next one when it is free: dynamic scheduling, whatever the tasks' lengths) and count each
  // finished task; the calling thread waits, reports progress, and joins. Without a progress
  // callback the calling thread is woken only when the last worker stops, not once per task.
  std::mutex mutex;
  std::condition_variable changed;
  int next = 0, done = 0, running = threads;
  bool stop = false;  // no further task starts (error with stop_on_error, or progress threw)
  const auto worker = [&](int thread) {
    for (;;) {
      int i = -1;
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (!stop && next < n && !Cancelled(options)) i = next++;
      }
      if (i < 0) break;
      RunOne(task, i, thread, &out[i]);
      {
        std::lock_guard<std::mutex> lock(mutex);
        ++done;
        if (options.stop_on_error && out[i].status == TaskStatus::kError) stop = true;
      }
      if (options.progress) changed.notify_one();
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      --running;
    }
    changed.notify_one();
  };

  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads));
  std::exception_ptr error;
  try {
    for (int t = 0; t < threads; ++t) pool.emplace_back(worker, t);
  } catch (...) {  // thread creation failed: go on with the threads we have, if any
    std::lock_guard<std::mutex> lock(mutex);
    running -= threads - static_cast<int>(pool.size());
    if (pool.empty()) error = std::current_exception();
  }
  if (!error) {
    int reported = 0;
    std::unique_lock<std::mutex> lock(mutex);
    for (;;) {
      changed.wait(lock, [&] { return done > reported || running == 0; });
      const int now = done;
      const bool finished = running == 0;
      if (now > reported && options.progress && !error) {
        lock.unlock();
        try {
          for (int d = reported + 1; d <= now; ++d) options.progress(d, n);
        } catch (...) {
          error = std::current_exception();
        }
        lock.lock();
        if (error) stop = true;
      }
      reported = now;
      if (finished) break;
    }
  }
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  return out;
}

// ----- rollouts ---------------------------------------------------------------------------------

void RunRollout(const Simulator& sim, const RolloutTask& task, const BatchRolloutOptions& options,
                Workspace* ws, RolloutResult* out) {
  if (options.state_stride < 0)
    throw std::invalid_argument("batch: state_stride must be >= 0, got " +
                                std::to_string(options.state_stride));
  if (task.inputs.empty() && task.num_steps < 0)
    throw std::invalid_argument("batch: num_steps must be >= 0, got " +
                                std::to_string(task.num_steps));
  const Params params = task.params ? *task.params : sim.DefaultParams();
  const int steps = task.inputs.empty() ? task.num_steps : static_cast<int>(task.inputs.size());
  const StepInput no_input;
  const int stride = options.state_stride;
  // Reserve for the kept states only.
  const std::size_t kept = stride == 0 ? 2 : static_cast<std::size_t>(steps / stride + 2);
  Trajectory& traj = out->trajectory;
  traj = Trajectory{};
  out->state_steps.clear();
  out->steps_done = 0;
  out->status = TaskStatus::kOk;
  traj.states.reserve(std::min<std::size_t>(kept, static_cast<std::size_t>(steps) + 1));
  if (options.step_reports) traj.steps.reserve(static_cast<std::size_t>(steps));
  State current = task.x0 ? *task.x0 : sim.InitialState();
  traj.states.push_back(current);
  out->state_steps.push_back(0);
  bool last_kept = true;  // is `current` already the last entry of traj.states?
  State next;
  for (int k = 0; k < steps; ++k) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed)) {
      out->status = TaskStatus::kCancelled;
      break;
    }
    const StepInput& u = task.inputs.empty() ? no_input : task.inputs[static_cast<std::size_t>(k)];
    StepInfo info = sim.Step(params, current, u, ws, &next);
    if (!info.ok) {
      traj.ok = false;
      // The wording of Simulator::Rollout.
      traj.failure = "step " + std::to_string(k) + " (t = " + std::to_string(current.t) +
                     " s): " + info.failure;
      traj.steps.push_back(std::move(info));
      break;
    }
    if (options.step_reports) traj.steps.push_back(std::move(info));
    std::swap(current, next);
    ++out->steps_done;
    last_kept = stride > 0 && out->steps_done % stride == 0;
    if (last_kept) {
      traj.states.push_back(current);
      out->state_steps.push_back(out->steps_done);
    }
  }
  if (!last_kept) {
    traj.states.push_back(std::move(current));
    out->state_steps.push_back(out->steps_done);
  }
}

namespace {

std::vector<RolloutResult> Rollouts(const Simulator& sim, int n,
                                    const std::function<const RolloutTask&(int, RolloutTask*)>& get,
                                    const BatchRolloutOptions& options) {
  std::vector<RolloutResult> results(static_cast<std::size_t>(n < 0 ? 0 : n));
  // One Workspace per thread, allocated by that thread on its first task: each lives in its
  // thread's malloc arena and on cache lines of its own (a contiguous array of workspaces would
  // put two threads' hot fields on one line).
  std::vector<std::unique_ptr<Workspace>> workspaces(
      static_cast<std::size_t>(BatchThreadCount(options, n)));
  const std::vector<TaskOutcome> outcomes = RunBatch(
      n,
      [&](int i, int thread) {
        std::unique_ptr<Workspace>& ws = workspaces[static_cast<std::size_t>(thread)];
        if (!ws) ws = std::make_unique<Workspace>();
        RolloutTask storage;
        RunRollout(sim, get(i, &storage), options, ws.get(), &results[static_cast<std::size_t>(i)]);
      },
      options);
  for (std::size_t i = 0; i < results.size(); ++i) {
    if (outcomes[i].status == TaskStatus::kOk) continue;  // kOk or a cancelled rollout
    results[i].status = outcomes[i].status;
    results[i].error = outcomes[i].error;
    results[i].exception = outcomes[i].exception;
  }
  return results;
}

}  // namespace

std::vector<RolloutResult> BatchRollouts(const Simulator& sim,
                                         const std::vector<RolloutTask>& tasks,
                                         const BatchRolloutOptions& options) {
  return Rollouts(
      sim, static_cast<int>(tasks.size()),
      [&tasks](int i, RolloutTask*) -> const RolloutTask& {
        return tasks[static_cast<std::size_t>(i)];
      },
      options);
}

std::vector<RolloutResult> BatchRollouts(const Simulator& sim, int n,
                                         const std::function<RolloutTask(int)>& make_task,
                                         const BatchRolloutOptions& options) {
  if (!make_task) throw std::invalid_argument("batch: make_task is empty");
  return Rollouts(
      sim, n,
      [&make_task](int i, RolloutTask* storage) -> const RolloutTask& {
        *storage = make_task(i);
        return *storage;
      },
      options);
}

}  // namespace vinci::sim
