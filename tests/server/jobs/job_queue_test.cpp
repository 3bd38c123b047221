// Tests of server/jobs/job_queue.hpp with a fake job (a gate the test opens) instead of the mesher: single-flight,
// bounded queue, per-job timeout, cancellation, failures, shutdown (service-test-list items 31, 33–35, 57).
#include "server/jobs/job_queue.hpp"

#include "core/stage_weights.hpp"
#include "support/eventually.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <latch>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace tracemesh::server {
namespace {

using namespace std::chrono_literals;

/// A job body that blocks until open() (polling its token so it can be cancelled) and counts its runs.
class gate_work {
 public:
  job_work work() {
    return [this](const std::string& id, const job_input&, progress_token& token) -> result<job_output> {
      runs_.fetch_add(1);
      started_.fetch_add(1);
      std::unique_lock lock(mutex_);
      while (!open_) {
        if (!token.report(mesh_stage::sampling, 0.5)) return status(errc::cancelled, "cancelled");
        changed_.wait_for(lock, 2ms);
      }
      if (id == failing_id) return status(errc::nothing_to_mesh, "nothing here");
      if (id == throwing_id) throw std::runtime_error("boom");
      job_output output;
      output.report = std::make_shared<const std::string>("OFF " + id);
      return output;
    };
  }
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  void wait_started(int count) {
    ASSERT_TRUE(tracemesh::testing::eventually([&] { return started_.load() >= count; }));
  }
  int runs() const { return runs_.load(); }

  static inline const std::string failing_id = "fail";
  static inline const std::string throwing_id = "throw";

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
  std::atomic<int> runs_{0};
  std::atomic<int> started_{0};
};

std::shared_ptr<const job_input> any_input() { return std::make_shared<job_input>(); }

job_queue_options options(unsigned workers, std::size_t max_queue, std::chrono::milliseconds timeout = 10s) {
  job_queue_options o;
  o.workers = workers;
  o.max_queue = max_queue;
  o.job_timeout = timeout;
  return o;
}

/// Waits until the job is final and returns its snapshot.
job_snapshot wait_final(const job_queue& queue, const std::string& id) {
  std::optional<job_snapshot> job;
  if (tracemesh::testing::eventually([&] { return (job = queue.find(id)) && proto::is_final(job->state); })) {
    return *job;
  }
  ADD_FAILURE() << "job " << id << " did not finish";
  return job ? *job : job_snapshot{};
}

TEST(JobQueue, IdenticalConcurrentSubmissionsRunOnceAndShareTheOutput) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(2, 8), gate.work(), stats);
  constexpr int clients = 20;
  std::latch all_notified(clients);
  std::mutex outputs_mutex;
  std::vector<std::string> outputs;
  std::vector<std::thread> threads;
  std::atomic<int> accepted{0};
  std::atomic<int> coalesced{0};
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back([&] {
      const submit_result r = queue.submit("same", any_input(), [&](const job_snapshot& s, const job_output* out) {
        EXPECT_EQ(s.state, job_state::done);
        std::lock_guard lock(outputs_mutex);
        outputs.push_back(out ? *out->report : "no output");
        all_notified.count_down();
      });
      (r.outcome == submit_outcome::accepted ? accepted : coalesced).fetch_add(1);
    });
  }
  for (auto& t : threads) t.join();
  gate.open();
  all_notified.wait();
  EXPECT_EQ(gate.runs(), 1);
  EXPECT_EQ(accepted.load(), 1);
  EXPECT_EQ(coalesced.load(), clients - 1);
  ASSERT_EQ(outputs.size(), static_cast<std::size_t>(clients));
  for (const auto& out : outputs) EXPECT_EQ(out, "OFF same");
}

TEST(JobQueue, FullQueueRefusesUntilItDrains) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(1, 2), gate.work(), stats);
  EXPECT_EQ(queue.submit("a", any_input()).outcome, submit_outcome::accepted);
  gate.wait_started(1);  // "a" runs; "b" and "c" fill the queue
  EXPECT_EQ(queue.submit("b", any_input()).outcome, submit_outcome::accepted);
  const submit_result c = queue.submit("c", any_input());
  EXPECT_EQ(c.outcome, submit_outcome::accepted);
  EXPECT_EQ(c.snapshot.queue_position, 1u);
  EXPECT_EQ(queue.queue_depth(), 2u);
  EXPECT_EQ(queue.submit("d", any_input()).outcome, submit_outcome::queue_full);
  EXPECT_EQ(queue.submit("b", any_input()).outcome, submit_outcome::coalesced);  // joining needs no slot
  gate.open();
  EXPECT_EQ(wait_final(queue, "c").state, job_state::done);
  EXPECT_EQ(queue.submit("d", any_input()).outcome, submit_outcome::accepted);
  EXPECT_EQ(wait_final(queue, "d").state, job_state::done);
}

TEST(JobQueue, TimeoutFailsTheJobAndFreesTheWorker) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(1, 4, 50ms), gate.work(), stats);
  queue.submit("slow", any_input());
  const job_snapshot slow = wait_final(queue, "slow");  // the gate stays closed: only the timeout ends it
  EXPECT_EQ(slow.state, job_state::failed);
  EXPECT_EQ(slow.error_code, "timeout");
  gate.open();
  queue.submit("next", any_input());
  EXPECT_EQ(wait_final(queue, "next").state, job_state::done);
}

TEST(JobQueue, CancelsQueuedJobsAtOnceAndRunningJobsThroughTheToken) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(1, 4), gate.work(), stats);
  queue.submit("running", any_input());
  gate.wait_started(1);
  std::atomic<bool> queued_listener_called{false};
  queue.submit("queued", any_input(), [&](const job_snapshot& s, const job_output* out) {
    EXPECT_EQ(s.state, job_state::cancelled);
    EXPECT_EQ(out, nullptr);
    queued_listener_called = true;
  });
  EXPECT_EQ(queue.cancel("queued"), cancel_outcome::cancelled);
  EXPECT_TRUE(queued_listener_called.load());
  EXPECT_EQ(queue.find("queued")->state, job_state::cancelled);
  EXPECT_EQ(queue.cancel("running"), cancel_outcome::cancelled);
  const job_snapshot running = wait_final(queue, "running");
  EXPECT_EQ(running.state, job_state::cancelled);
  EXPECT_EQ(running.error_code, "cancelled");
  EXPECT_EQ(queue.cancel("running"), cancel_outcome::already_final);
  EXPECT_EQ(queue.cancel("unknown"), cancel_outcome::not_found);
  EXPECT_EQ(gate.runs(), 1);  // the queued job never ran
}

TEST(JobQueue, FailuresAndExceptionsFailOnlyTheirJobAndAreRetriedOnResubmission) {
  gate_work gate;
  gate.open();
  metrics stats;
  job_queue queue(options(1, 4), gate.work(), stats);
  queue.submit(gate_work::failing_id, any_input());
  queue.submit(gate_work::throwing_id, any_input());
  queue.submit("fine", any_input());
  const job_snapshot failed = wait_final(queue, gate_work::failing_id);
  EXPECT_EQ(failed.state, job_state::failed);
  EXPECT_EQ(failed.error_code, "nothing_to_mesh");
  const job_snapshot threw = wait_final(queue, gate_work::throwing_id);
  EXPECT_EQ(threw.state, job_state::failed);
  EXPECT_EQ(threw.error_code, "internal_error");
  EXPECT_NE(threw.error.message().find("boom"), std::string::npos);
  EXPECT_EQ(wait_final(queue, "fine").state, job_state::done);
  // A failed job is not remembered as a result: submitting it again runs it again.
  EXPECT_EQ(queue.submit(gate_work::failing_id, any_input()).outcome, submit_outcome::accepted);
  wait_final(queue, gate_work::failing_id);
  EXPECT_EQ(gate.runs(), 4);
}

TEST(JobQueue, ReportsProgressWhileRunning) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(1, 4), gate.work(), stats);
  queue.submit("job", any_input());
  gate.wait_started(1);
  std::optional<job_snapshot> job;
  ASSERT_TRUE(tracemesh::testing::eventually([&] { return (job = queue.find("job")) && job->progress > 0.0; }))
      << "the gate reports sampling/0.5 every 2 ms";
  EXPECT_EQ(job->state, job_state::running);
  EXPECT_EQ(job->stage, mesh_stage::sampling);
  EXPECT_GT(job->progress, 0.0);
  EXPECT_LT(job->progress, 1.0);
  EXPECT_EQ(queue.running_jobs(), 1u);
  gate.open();
  const job_snapshot done = wait_final(queue, "job");
  EXPECT_EQ(done.progress, 1.0);
  EXPECT_EQ(*done.report, "OFF job");
}

TEST(JobQueue, ProgressFollowsEitherMethodsStagesAndNeverGoesBack) {
  // The trace method's stages (roots → tracing → triangulating, no sampling), then the mesher's own "done" before
  // the job encodes, then a stage out of order: the job's progress only moves forward, and its stage is never
  // "done" before the job is.
  metrics stats;
  job_queue* queue_seen = nullptr;
  std::vector<std::pair<mesh_stage, double>> seen;
  const job_work work = [&](const std::string& id, const job_input&, progress_token& token) -> result<job_output> {
    const std::pair<mesh_stage, double> reports[] = {
        {mesh_stage::culling, 1.0},      {mesh_stage::roots, 0.5},     {mesh_stage::tracing, 0.0},
        {mesh_stage::tracing, 0.75},     {mesh_stage::triangulating, 1.0}, {mesh_stage::certifying, 1.0},
        {mesh_stage::done, 1.0},         {mesh_stage::encoding, 0.0},  {mesh_stage::sampling, 0.9}};
    for (const auto& [stage, fraction] : reports) {
      token.report(stage, fraction);
      const auto job = queue_seen->find(id);
      seen.emplace_back(job ? job->stage : mesh_stage::reading, job ? job->progress : -1.0);
    }
    job_output output;
    output.report = std::make_shared<const std::string>("{}");
    return output;
  };
  job_queue queue(options(1, 4), work, stats);
  queue_seen = &queue;
  auto trace_input = std::make_shared<job_input>();
  trace_input->params.method = mesh_method::trace;  // progress follows the trace path's stage weights
  queue.submit("trace", trace_input);
  const job_snapshot done = wait_final(queue, "trace");
  ASSERT_EQ(seen.size(), 9u);
  EXPECT_EQ(seen[2].first, mesh_stage::tracing);
  EXPECT_GT(seen[2].second, seen[1].second) << "tracing comes after roots";
  EXPECT_GT(seen[3].second, seen[2].second) << "and advances within its share";
  EXPECT_GT(seen[4].second, seen[3].second);
  for (std::size_t i = 1; i < seen.size(); ++i) {
    EXPECT_GE(seen[i].second, seen[i - 1].second) << "report " << i;
    EXPECT_GT(seen[i].second, 0.0) << "report " << i;
    EXPECT_LT(seen[i].second, 1.0) << "report " << i << ": only the finished job is complete";
    EXPECT_NE(seen[i].first, mesh_stage::done) << "report " << i;
  }
  EXPECT_EQ(seen[7].first, mesh_stage::encoding);
  EXPECT_EQ(done.stage, mesh_stage::done);
  EXPECT_EQ(done.progress, 1.0);
}

TEST(JobQueue, ProgressIsProportionalToTheJobPathsStageWeights) {
  // The same report (half of the refining stage) is further along for a lattice job than for a trace job: the
  // quality pass is most of a lattice run but comes after tracing in a trace run, and weighs less there.
  metrics stats;
  job_queue* queue_seen = nullptr;
  std::map<std::string, double> seen;
  const job_work work = [&](const std::string& id, const job_input&, progress_token& token) -> result<job_output> {
    token.report(mesh_stage::refining, 0.5);
    seen[id] = queue_seen->find(id)->progress;
    job_output output;
    output.report = std::make_shared<const std::string>("{}");
    return output;
  };
  job_queue queue(options(1, 4), work, stats);
  queue_seen = &queue;
  for (const mesh_method method : {mesh_method::lattice, mesh_method::trace}) {
    auto input = std::make_shared<job_input>();
    input->params.method = method;
    queue.submit(method_name(method), input);
    wait_final(queue, method_name(method));
    EXPECT_DOUBLE_EQ(seen[method_name(method)],
                     overall_progress(method, refine_mode::full, mesh_stage::refining, 0.5))
        << method_name(method);
  }
  EXPECT_NE(seen["lattice"], seen["trace"]);
}

TEST(JobQueue, ShutdownLetsRunningJobsFinishWithinGraceThenFailsTheRest) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(1, 4), gate.work(), stats);
  queue.submit("running", any_input());
  gate.wait_started(1);
  std::atomic<int> shutdown_failures{0};
  queue.submit("waiting", any_input(), [&](const job_snapshot& s, const job_output*) {
    if (s.state == job_state::failed && s.error_code == "shutdown") shutdown_failures.fetch_add(1);
  });
  // Nobody opens the gate: after the grace period both jobs end, none of them done (a shutdown that waited for the
  // job would hang here, until ctest's timeout).
  queue.shutdown(100ms);
  EXPECT_EQ(shutdown_failures.load(), 1);
  EXPECT_EQ(queue.find("running")->error_code, "shutdown");
  EXPECT_EQ(queue.submit("late", any_input()).outcome, submit_outcome::shutting_down);
  EXPECT_FALSE(queue.accepting());
}

TEST(JobQueue, ShutdownWaitsForJobsThatFinishInTime) {
  gate_work gate;
  metrics stats;
  job_queue queue(options(1, 4), gate.work(), stats);
  queue.submit("job", any_input());
  gate.wait_started(1);
  // The job ends while shutdown() waits (it has stopped accepting); the grace only bounds a failing test.
  std::thread opener([&] {
    tracemesh::testing::eventually([&] { return !queue.accepting(); });
    gate.open();
  });
  queue.shutdown(std::chrono::minutes(2));
  opener.join();
  EXPECT_EQ(queue.find("job")->state, job_state::done);
}

TEST(JobQueue, ForgetsOldFinishedJobsBeyondTheRecordLimit) {
  gate_work gate;
  gate.open();
  metrics stats;
  job_queue_options o = options(1, 8);
  o.max_records = 2;
  job_queue queue(o, gate.work(), stats);
  for (const char* id : {"j1", "j2", "j3"}) {
    queue.submit(id, any_input());
    wait_final(queue, id);
  }
  EXPECT_FALSE(queue.find("j1"));
  EXPECT_TRUE(queue.find("j2"));
  EXPECT_TRUE(queue.find("j3"));
}


// ---- the small-job lane (issue 12, finding 10: a small job waited behind big ones) ------------------------------

/// Polls until job `id` is in `state` (tracemesh::testing::eventually).
bool eventually_state(const job_queue& queue, const std::string& id, job_state state) {
  return tracemesh::testing::eventually([&] {
    const auto job = queue.find(id);
    return job && job->state == state;
  });
}

/// A molecule of `atoms` identical atoms (only the count matters to the queue).
std::shared_ptr<const job_input> input_of(std::size_t atoms) {
  auto input = std::make_shared<job_input>();
  input->mol.atoms.resize(atoms);
  return input;
}

/// Big jobs (more than `small_atoms` atoms) block until open(); small ones finish at once.
class big_gate_work {
 public:
  explicit big_gate_work(std::size_t small_atoms) : small_atoms_(small_atoms) {}
  job_work work() {
    return [this](const std::string&, const job_input& input, progress_token& token) -> result<job_output> {
      std::unique_lock lock(mutex_);
      while (!open_ && input.mol.atoms.size() > small_atoms_) {
        if (!token.report(mesh_stage::sampling, 0.5)) return status(errc::cancelled, "cancelled");
        changed_.wait_for(lock, 2ms);
      }
      return job_output{};
    };
  }
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }

 private:
  const std::size_t small_atoms_;
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
};

TEST(JobQueue, ASmallJobPassesBigOnesOnTheSmallJobLane) {
  metrics stats;
  big_gate_work gate(10);
  job_queue_options o = options(1, 8);
  o.small_job_workers = 1;
  o.small_job_max_atoms = 10;
  job_queue queue(o, gate.work(), stats);
  ASSERT_EQ(queue.submit("big-1", input_of(100)).outcome, submit_outcome::accepted);
  ASSERT_TRUE(eventually_state(queue, "big-1", job_state::running));
  ASSERT_EQ(queue.submit("big-2", input_of(100)).outcome, submit_outcome::accepted);
  ASSERT_EQ(queue.submit("small", input_of(10)).outcome, submit_outcome::accepted);

  EXPECT_EQ(wait_final(queue, "small").state, job_state::done) << "the lane ran it past both big jobs";
  EXPECT_EQ(queue.find("big-1")->state, job_state::running);
  EXPECT_EQ(queue.find("big-2")->state, job_state::queued) << "the lane never takes a big job";
  gate.open();
  EXPECT_EQ(wait_final(queue, "big-1").state, job_state::done);
  EXPECT_EQ(wait_final(queue, "big-2").state, job_state::done);
}

TEST(JobQueue, WithoutTheLaneASmallJobWaitsItsTurn) {
  metrics stats;
  big_gate_work gate(10);
  job_queue queue(options(1, 8), gate.work(), stats);
  ASSERT_EQ(queue.submit("big-1", input_of(100)).outcome, submit_outcome::accepted);
  ASSERT_TRUE(eventually_state(queue, "big-1", job_state::running));
  ASSERT_EQ(queue.submit("big-2", input_of(100)).outcome, submit_outcome::accepted);
  ASSERT_EQ(queue.submit("small", input_of(10)).outcome, submit_outcome::accepted);
  const auto small = queue.find("small");
  EXPECT_EQ(small->state, job_state::queued);
  EXPECT_EQ(small->queue_position, 1u) << "general workers take jobs oldest first";
  gate.open();
  EXPECT_EQ(wait_final(queue, "small").state, job_state::done);
}

}  // namespace
}  // namespace tracemesh::server
