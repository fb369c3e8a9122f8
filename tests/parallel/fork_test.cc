// ForkDistributor: Distributor::Map's contract over forked processes, and what a fork adds
// (fn reads the caller's memory; its side effects stay in the child; a crashed child is
// reported, not hung on).
#include "vinci/parallel/fork.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/parallel/wire.h"

namespace vinci::parallel {
namespace {

// Items i ↦ i² + the job's offset, one int64 each.
Buffer Squares(const Buffer& job, int begin, int end) {
  const auto offset = Reader(job).Get<std::int64_t>();
  Buffer out;
  Writer w(&out);
  for (int i = begin; i < end; ++i) w.Put<std::int64_t>(offset + std::int64_t{i} * i);
  return out;
}

Buffer Job(std::int64_t offset) {
  Buffer job;
  Writer(&job).Put<std::int64_t>(offset);
  return job;
}

TEST(ForkDistributor, MapsLikeTheLocalDistributorForAnyProcessCount) {
  LocalDistributor local;
  for (int n : {0, 1, 5, 37}) {
    const Buffer want = local.Map(Job(7), n, Squares);
    for (int processes : {1, 2, 3}) {
      for (int chunk : {0, 1, 4}) {
        ForkDistributor fork(processes);
        MapOptions o;
        o.chunk = chunk;
        std::vector<int> seen(static_cast<std::size_t>(n), 0);
        int last_done = 0;
        o.on_chunk = [&](int b, int e, const Buffer& result) {
          EXPECT_EQ(result, Squares(Job(7), b, e));
          for (int i = b; i < e; ++i) ++seen[static_cast<std::size_t>(i)];
        };
        o.progress = [&](int done, int total) {
          EXPECT_EQ(total, n);
          EXPECT_GT(done, last_done);
          last_done = done;
        };
        EXPECT_EQ(fork.Map(Job(7), n, Squares, o), want) << processes << " processes, n " << n;
        for (int i = 0; i < n; ++i) EXPECT_EQ(seen[static_cast<std::size_t>(i)], 1) << i;
        EXPECT_EQ(last_done, n);
        long long items = 0;
        for (long long k : fork.ItemsPerRank()) items += k;
        EXPECT_EQ(items, n);
        EXPECT_EQ(fork.size(), processes);
        EXPECT_TRUE(fork.root());
      }
    }
  }
}

// A child reads the caller's memory (not in the job) as it was at the fork; what it writes
// stays in the child. Each chunk runs in a process of its own (distinct pids).
TEST(ForkDistributor, ChildrenSeeTheCallersStateAndKeepTheirSideEffects) {
  std::vector<double> table = {0.5, 1.5, 2.5, 3.5, 4.5, 5.5};
  int writes = 0;
  ForkDistributor fork(2);
  MapOptions o;
  o.chunk = 1;
  const Buffer out = fork.Map(
      Buffer(), static_cast<int>(table.size()),
      [&](const Buffer&, int b, int) {
        ++writes;
        table[static_cast<std::size_t>(b)] = -1.0;
        Buffer r;
        Writer w(&r);
        w.Put<double>(table[static_cast<std::size_t>(b) == 0 ? 1 : 0] + b);
        w.Put<std::int64_t>(::getpid());
        return r;
      },
      o);
  EXPECT_EQ(writes, 0);
  EXPECT_EQ(table[0], 0.5);
  Reader r(out);
  std::vector<std::int64_t> pids;
  for (std::size_t b = 0; b < table.size(); ++b) {
    // Each child changed only its own entry: entry 0 (or 1 for chunk 0) is the caller's.
    EXPECT_EQ(r.Get<double>(), (b == 0 ? 1.5 : 0.5) + static_cast<double>(b));
    pids.push_back(r.Get<std::int64_t>());
    EXPECT_NE(pids.back(), ::getpid());
  }
  EXPECT_TRUE(r.done());
  for (std::size_t i = 0; i < pids.size(); ++i)
    for (std::size_t j = i + 1; j < pids.size(); ++j) EXPECT_NE(pids[i], pids[j]);
}

// The lowest-index failing chunk's error is raised, with its type; a child that dies without
// a result (abort, _exit) is reported with how it ended.
TEST(ForkDistributor, ReportsFailuresAndDeadChildren) {
  ForkDistributor fork(2);
  MapOptions o;
  o.chunk = 1;
  try {
    fork.Map(
        Buffer(), 6,
        [](const Buffer&, int b, int) -> Buffer {
          if (b == 3) throw std::invalid_argument("item 3 is bad");
          if (b == 4) throw std::runtime_error("item 4 failed");
          return Buffer(1, static_cast<char>(b));
        },
        o);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "item 3 is bad");
  }
  try {
    fork.Map(
        Buffer(), 3,
        [](const Buffer&, int b, int) -> Buffer {
          if (b == 1) std::abort();
          return Buffer(1, 'x');
        },
        o);
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("items [1, 2)"), std::string::npos) << what;
    EXPECT_NE(what.find("signal " + std::to_string(SIGABRT)), std::string::npos) << what;
  }
  try {
    fork.Map(
        Buffer(), 2, [](const Buffer&, int, int) -> Buffer { ::_exit(3); }, o);
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("exited with status 3"), std::string::npos) << e.what();
  }
  // Still usable after failures.
  EXPECT_EQ(fork.Map(Job(1), 4, Squares), LocalDistributor().Map(Job(1), 4, Squares));
}

TEST(ForkDistributor, RejectsNoProcesses) {
  EXPECT_THROW(ForkDistributor(0), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::parallel
