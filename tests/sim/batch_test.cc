// The batch API (simulator/batch.h): order, per-thread workspaces, bit-identical results for any
// thread count, progress on the calling thread, cancellation, exceptions captured per task, and
// the keep options of rollouts.
#include "vinci/sim/simulator/batch.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "test_util.h"
#include "vinci/sim/model/motion_input.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;
using testing::WithParams;

using testing::SameBits;

bool SameState(const State& a, const State& b) {
  return std::memcmp(&a.t, &b.t, sizeof a.t) == 0 && SameBits(a.q, b.q) && SameBits(a.v, b.v) &&
         SameBits(a.warm_start, b.warm_start);
}

// The sliding block with μ varied per rollout: stops at v0/(μg), so the rollouts differ.
std::vector<RolloutTask> FrictionTasks(const Simulator& sim, int n, int steps) {
  std::vector<RolloutTask> tasks(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    tasks[i].params = WithParams(sim, {{"mu.default", 0.2 + 0.05 * i}});
    tasks[i].num_steps = steps;
  }
  return tasks;
}

TEST(BatchTest, RunBatchRunsEveryTaskOnceInOrderSlots) {
  for (int threads : {1, 2, 4}) {
    const int n = 37;
    std::vector<std::atomic<int>> runs(n);
    std::vector<int> slot(n, -1);
    BatchOptions o;
    o.threads = threads;
    const std::vector<TaskOutcome> out = RunBatch(
        n,
        [&](int i, int thread) {
          ++runs[i];
          slot[i] = i * i;
          EXPECT_GE(thread, 0);
          EXPECT_LT(thread, threads);
        },
        o);
    ASSERT_EQ(out.size(), static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(runs[i].load(), 1) << "task " << i << ", " << threads << " threads";
      EXPECT_EQ(slot[i], i * i);
      EXPECT_EQ(out[i].status, TaskStatus::kOk);
    }
  }
  EXPECT_TRUE(RunBatch(0, [](int, int) {}).empty());
  BatchOptions bad;
  bad.threads = 0;
  EXPECT_THROW(RunBatch(
                   3, [](int, int) {}, bad),
               std::invalid_argument);
}

TEST(BatchTest, ExceptionsAreCapturedPerTaskAndNeverTerminate) {
  for (int threads : {1, 2, 4}) {
    BatchOptions o;
    o.threads = threads;
    const std::vector<TaskOutcome> out = RunBatch(
        10,
        [](int i, int) {
          if (i % 3 == 1) throw std::invalid_argument("bad task " + std::to_string(i));
          if (i == 8) throw 42;  // not a std::exception
        },
        o);
    for (int i = 0; i < 10; ++i) {
      if (i % 3 == 1) {
        EXPECT_EQ(out[i].status, TaskStatus::kError);
        EXPECT_EQ(out[i].error, "bad task " + std::to_string(i));
        EXPECT_THROW(std::rethrow_exception(out[i].exception), std::invalid_argument);
      } else if (i == 8) {
        EXPECT_EQ(out[i].status, TaskStatus::kError);
        EXPECT_EQ(out[i].error, "unknown exception");
      } else {
        EXPECT_EQ(out[i].status, TaskStatus::kOk) << i;
      }
    }
    try {
      RethrowFirstError(out);
      ADD_FAILURE() << "no exception rethrown";
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), "bad task 1");
    }
  }
}

// stop_on_error: tasks start in order, so the lowest-index failing task is the same for any
// thread count, and nothing much beyond it runs.
TEST(BatchTest, StopOnErrorFindsTheFirstFailingTask) {
  for (int threads : {1, 2, 4}) {
    std::atomic<int> ran{0};
    BatchOptions o;
    o.threads = threads;
    o.stop_on_error = true;
    const std::vector<TaskOutcome> out = RunBatch(
        200,
        [&](int i, int) {
          ++ran;
          if (i == 5 || i == 7 || i == 150) throw std::runtime_error("fail " + std::to_string(i));
          std::this_thread::sleep_for(std::chrono::microseconds(200));
        },
        o);
    int first_error = -1;
    for (int i = 0; i < 200 && first_error < 0; ++i)
      if (out[i].status == TaskStatus::kError) first_error = i;
    EXPECT_EQ(first_error, 5) << threads << " threads";
    for (int i = 0; i < 5; ++i) EXPECT_EQ(out[i].status, TaskStatus::kOk);
    EXPECT_EQ(out[150].status, TaskStatus::kCancelled);
    EXPECT_LT(ran.load(), 150);
  }
}

TEST(BatchTest, ProgressRunsOnTheCallingThreadAndCancelStopsNewTasks) {
  for (int threads : {1, 2, 4}) {
    const std::thread::id caller = std::this_thread::get_id();
    std::atomic<bool> cancel{false};
    std::vector<int> seen;
    BatchOptions o;
    o.threads = threads;
    o.cancel = &cancel;
    o.progress = [&](int done, int total) {
      EXPECT_EQ(std::this_thread::get_id(), caller);
      EXPECT_EQ(total, 100);
      seen.push_back(done);
      if (done >= 10) cancel = true;
    };
    std::atomic<int> ran{0};
    const std::vector<TaskOutcome> out = RunBatch(
        100,
        [&](int, int) {
          ++ran;
          std::this_thread::sleep_for(std::chrono::microseconds(300));
        },
        o);
    ASSERT_FALSE(seen.empty());
    for (std::size_t k = 0; k < seen.size(); ++k) EXPECT_EQ(seen[k], static_cast<int>(k) + 1);
    EXPECT_EQ(seen.back(), ran.load());  // the last report counts every task that ran
    EXPECT_LT(ran.load(), 100);
    int ok = 0, cancelled = 0;
    for (const TaskOutcome& t : out) {
      ok += t.status == TaskStatus::kOk;
      cancelled += t.status == TaskStatus::kCancelled;
    }
    EXPECT_EQ(ok, ran.load());
    EXPECT_EQ(ok + cancelled, 100);
  }
  // Without cancellation the last report is (total, total).
  for (int threads : {1, 3}) {
    int last = 0;
    BatchOptions o;
    o.threads = threads;
    o.progress = [&](int done, int) { last = done; };
    RunBatch(
        17, [](int, int) {}, o);
    EXPECT_EQ(last, 17);
  }
}

TEST(BatchTest, ThrowingProgressPropagatesAfterJoiningTheThreads) {
  for (int threads : {1, 2}) {
    BatchOptions o;
    o.threads = threads;
    int calls = 0;
    o.progress = [&calls](int done, int) {
      ++calls;
      if (done >= 2) throw std::runtime_error("stop here");
    };
    std::atomic<int> ran{0};
    const auto task = [&ran](int, int) {
      ++ran;
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    };
    EXPECT_THROW(RunBatch(50, task, o), std::runtime_error);
    EXPECT_EQ(calls, 2);  // not called again after it threw
    EXPECT_LT(ran.load(), 50);
  }
}

TEST(BatchTest, BatchMapMakesOneWorkspacePerThread) {
  struct Counter {
    int uses = 0;
    std::thread::id owner = std::this_thread::get_id();
  };
  for (int threads : {1, 2, 4}) {
    std::atomic<int> made{0};
    BatchOptions o;
    o.threads = threads;
    const auto out = BatchMap<Counter>(
        40, std::function<Counter()>([&] {
          ++made;
          return Counter{};
        }),
        [](int i, Counter& ws) {
          EXPECT_EQ(ws.owner, std::this_thread::get_id());  // made in, and used by, one thread
          ++ws.uses;
          return 2.0 * i;
        },
        o);
    EXPECT_GE(made.load(), 1);
    EXPECT_LE(made.load(), threads);
    for (int i = 0; i < 40; ++i) {
      EXPECT_EQ(out[i].status, TaskStatus::kOk);
      EXPECT_EQ(out[i].value, 2.0 * i);
    }
  }
  // Default-constructed workspaces.
  const auto sq = BatchMap<int>(5, [](int i, int& ws) { return i * i + ws; });
  for (int i = 0; i < 5; ++i) EXPECT_EQ(sq[i].value, i * i);
}

// The central promise: a batch of rollouts equals the sequential Simulator::Rollout bit for bit,
// for 1, 2 and 4 threads.
TEST(BatchTest, RolloutsAreBitIdenticalToRolloutForAnyThreadCount) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const std::vector<RolloutTask> tasks = FrictionTasks(sim, 9, 300);
  std::vector<Trajectory> reference;
  for (const RolloutTask& t : tasks)
    reference.push_back(sim.Rollout(*t.params, sim.InitialState(), t.num_steps));
  // The rollouts differ (μ differs), so the comparison below is not vacuous.
  ASSERT_FALSE(SameState(reference[0].states.back(), reference[1].states.back()));
  for (int threads : {1, 2, 4}) {
    BatchRolloutOptions o;
    o.threads = threads;
    const std::vector<RolloutResult> r = BatchRollouts(sim, tasks, o);
    ASSERT_EQ(r.size(), tasks.size());
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      EXPECT_EQ(r[i].status, TaskStatus::kOk);
      const Trajectory& a = r[i].trajectory;
      const Trajectory& b = reference[i];
      ASSERT_EQ(a.states.size(), b.states.size());
      ASSERT_EQ(a.steps.size(), b.steps.size());
      EXPECT_EQ(a.ok, b.ok);
      EXPECT_EQ(r[i].steps_done, 300);
      for (std::size_t k = 0; k < a.states.size(); ++k) {
        ASSERT_TRUE(SameState(a.states[k], b.states[k]))
            << "rollout " << i << " state " << k << ", " << threads << " threads";
        EXPECT_EQ(r[i].state_steps[k], static_cast<int>(k));
      }
      for (std::size_t k = 0; k < a.steps.size(); ++k)
        EXPECT_EQ(a.steps[k].contacts, b.steps[k].contacts);
    }
  }
}

// Rollouts with per-step plate motions (motion_input.h) share a thread's workspace, whose
// motion cache must follow each task's inputs: same results as sequential Rollout calls.
TEST(BatchTest, RolloutsWithMotionInputsAreBitIdenticalForAnyThreadCount) {
  const Simulator sim(LoadExample("plate_conveyor.yaml"));
  const Scene& s = sim.scene();
  const int plate = s.FindBody("plate");
  std::vector<RolloutTask> tasks(6);
  for (int i = 0; i < 6; ++i) {
    PrescribedMotion m = s.bodies[plate].motion;
    m.dofs[0].harmonics[0].phase += 0.5 * i;
    if (i % 3 == 2) {
      tasks[i].num_steps = 200;  // the scene's own motion
    } else {
      tasks[i].inputs =
          PhaseLockedSegment(s, plate, m, 0.0, s.bodies[plate].X_WB0, 1, s.options.dt).inputs;
    }
  }
  std::vector<State> reference;
  for (const RolloutTask& t : tasks) {
    const Trajectory tr = t.inputs.empty()
                              ? sim.Rollout(sim.DefaultParams(), sim.InitialState(), t.num_steps)
                              : sim.Rollout(sim.DefaultParams(), sim.InitialState(), t.inputs);
    ASSERT_TRUE(tr.ok) << tr.failure;
    reference.push_back(tr.states.back());
  }
  ASSERT_FALSE(SameState(reference[0], reference[1]));
  for (int threads : {1, 2, 4}) {
    BatchRolloutOptions o;
    o.threads = threads;
    o.state_stride = 0;
    const std::vector<RolloutResult> r = BatchRollouts(sim, tasks, o);
    for (int i = 0; i < 6; ++i)
      EXPECT_TRUE(SameState(r[i].trajectory.states.back(), reference[i]))
          << "rollout " << i << ", " << threads << " threads";
  }
}

TEST(BatchTest, RolloutsKeepOnlyWhatIsAsked) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const std::vector<RolloutTask> tasks = FrictionTasks(sim, 3, 103);
  const Trajectory full = sim.Rollout(*tasks[1].params, sim.InitialState(), 103);
  ASSERT_TRUE(full.ok);
  BatchRolloutOptions o;
  o.threads = 2;
  o.state_stride = 10;
  o.step_reports = false;
  const std::vector<RolloutResult> r = BatchRollouts(sim, tasks, o);
  const RolloutResult& a = r[1];
  // x0, 10, 20, ..., 100 and the last (103).
  const std::vector<int> expected = {0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 103};
  EXPECT_EQ(a.state_steps, expected);
  ASSERT_EQ(a.trajectory.states.size(), expected.size());
  for (std::size_t j = 0; j < expected.size(); ++j)
    EXPECT_TRUE(SameState(a.trajectory.states[j], full.states[expected[j]])) << expected[j];
  EXPECT_TRUE(a.trajectory.steps.empty());
  // Stride 0: x0 and the final state only; a stride dividing the step count keeps no duplicate.
  o.state_stride = 0;
  const RolloutResult b = BatchRollouts(sim, tasks, o)[1];
  EXPECT_EQ(b.state_steps, (std::vector<int>{0, 103}));
  EXPECT_TRUE(SameState(b.trajectory.states.back(), full.states.back()));
  o.state_stride = 103;
  EXPECT_EQ(BatchRollouts(sim, tasks, o)[1].state_steps, (std::vector<int>{0, 103}));
}

TEST(BatchTest, RolloutTaskErrorsAndInputsAreReportedPerTask) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  std::vector<RolloutTask> tasks = FrictionTasks(sim, 4, 20);
  State bad = sim.InitialState();
  bad.q.resize(1);  // wrong size: Simulator::Step throws std::invalid_argument
  tasks[1].x0 = bad;
  tasks[2].params = Params{};  // wrong size
  tasks[3].inputs.resize(5);   // inputs given: 5 steps, num_steps ignored
  for (int threads : {1, 2}) {
    BatchRolloutOptions o;
    o.threads = threads;
    const std::vector<RolloutResult> r = BatchRollouts(sim, tasks, o);
    EXPECT_EQ(r[0].status, TaskStatus::kOk);
    EXPECT_EQ(r[1].status, TaskStatus::kError);
    EXPECT_NE(r[1].error.find("state has"), std::string::npos) << r[1].error;
    EXPECT_EQ(r[2].status, TaskStatus::kError);
    EXPECT_EQ(r[3].status, TaskStatus::kOk);
    EXPECT_EQ(r[3].steps_done, 5);
  }
}

TEST(BatchTest, GeneratedTasksAndCancelledRollouts) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const std::vector<RolloutTask> tasks = FrictionTasks(sim, 6, 50);
  BatchRolloutOptions o;
  o.threads = 2;
  const std::vector<RolloutResult> a = BatchRollouts(sim, tasks, o);
  const std::vector<RolloutResult> b = BatchRollouts(
      sim, 6, [&tasks](int i) { return tasks[static_cast<std::size_t>(i)]; }, o);
  for (int i = 0; i < 6; ++i)
    EXPECT_TRUE(SameState(a[i].trajectory.states.back(), b[i].trajectory.states.back()));
  std::atomic<bool> cancel{true};
  o.cancel = &cancel;
  for (const RolloutResult& r : BatchRollouts(sim, tasks, o))
    EXPECT_EQ(r.status, TaskStatus::kCancelled);
  // A rollout run directly with a set flag stops before its first step, keeping x0.
  RolloutResult one;
  Workspace ws;
  RunRollout(sim, tasks[0], o, &ws, &one);
  EXPECT_EQ(one.status, TaskStatus::kCancelled);
  EXPECT_EQ(one.steps_done, 0);
  EXPECT_EQ(one.trajectory.states.size(), 1u);
}

}  // namespace
}  // namespace vinci::sim
