// The tracker's thread pool: every task runs once, on any number of threads, and a task that
// throws ends its run with that exception once the others have finished (it once called
// std::terminate from a worker, or unwound while workers still held the task).
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "../src/worker_pool.hpp"

using depowder::tracker::WorkerPool;

TEST(WorkerPool, EveryTaskRunsOnce) {
  for (int threads : {1, 2, 4}) {
    WorkerPool pool(threads);
    EXPECT_EQ(pool.threads(), threads);
    for (std::size_t n : {0, 1, 7, 100}) {
      std::vector<std::atomic<int>> runs(n);
      pool.run(n, [&](std::size_t i) { ++runs[i]; });
      for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(runs[i].load(), 1) << threads << " threads, task " << i;
    }
  }
}

TEST(WorkerPool, AThrowingTaskEndsTheRunWithItsException) {
  for (int threads : {1, 2, 4}) {
    WorkerPool pool(threads);
    std::atomic<int> done{0};
    try {
      pool.run(20, [&](std::size_t i) {
        if (i == 3 || i == 11) throw std::runtime_error("task " + std::to_string(i));
        ++done;
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("task ", 0), 0u) << e.what();
    }
    EXPECT_EQ(done.load(), 18) << threads << " threads";  // the others all ran to their end
    pool.run(5, [&](std::size_t) { ++done; });            // and the pool still works
    EXPECT_EQ(done.load(), 23);
  }
}
