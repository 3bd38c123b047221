// Several tracemeshd replicas sharing one Redis (`--store redis://…`) and one result directory, as real processes on
// loopback ports: work spreads over the replicas, a job is meshed once however many replicas are asked for it, any
// replica answers for any job (status, events, DELETE with the owner token), a kill -9'd replica's job is finished by
// another, and a Redis restart (append-only file on) loses nothing accepted. nginx in front (docker/nginx's
// replicas upstream) spreads requests and stops routing to a dead replica. Molecules are the small ones of the
// ladder, timeouts short (flags), so the whole file runs in well under a minute and a half.
// A test that needs a job still running when it acts (cancels it, kills its replica) does not count on the mesher
// being slow: it plays a third replica that is meshing that job (held_run holds the job's run lease), so the replica
// that takes the job follows it, running, until the test lets go. No wait depends on the machine's speed: waits are
// tracemesh::testing::eventually(), whose deadline only bounds how long a failing test takes.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/io/structure/molecule_reader.hpp"
#include "proto/api_types.hpp"
#include "server/admission/server_limits.hpp"
#include "server/jobs/job_id.hpp"
#include "server/redis/redis_run_lease.hpp"
#include "support/event_stream.hpp"
#include "support/eventually.hpp"
#include "support/nginx_process.hpp"
#include "support/redis_process.hpp"
#include "support/test_http_client.hpp"
#include "support/test_paths.hpp"
#include "support/tracemeshd_process.hpp"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using tracemesh::testing::eventually;
using tracemesh::testing::http_reply;
using tracemesh::testing::molecule_path;
using tracemesh::testing::read_file;
using tracemesh::testing::round_trip;
using tracemesh::testing::server_process;
using tracemesh::testing::temp_dir;

/// The reclaim timeout the replicas run with: a dead replica's job is taken over after this long.
constexpr auto reclaim_timeout = 2s;

/// A PQR of the shared ladder.
std::string molecule(const std::string& name) { return read_file(molecule_path(name)); }

/// One kind of job: a molecule and its form fields.
struct job_spec {
  std::string molecule;
  std::vector<std::pair<std::string, std::string>> fields;
};

/// The id the service gives the job of `spec` (server/jobs/job_id.hpp), known before it is submitted: read and
/// parsed as POST /jobs does.
std::string job_id_of(const job_spec& spec) {
  const auto read = tracemesh::read_molecule(molecule(spec.molecule), tracemesh::structure_options{},
                                             tracemesh::mesh_limits{}, tracemesh::server::server_limits{}.max_pqr_bytes);
  const auto params = tracemesh::proto::parse_mesh_params([&](std::string_view name) -> std::optional<std::string> {
    for (const auto& [field, value] : spec.fields) {
      if (field == name) return value;
    }
    return std::nullopt;
  });
  EXPECT_TRUE(read.ok() && params.ok()) << spec.molecule;
  return read.ok() && params.ok() ? tracemesh::server::compute_job_id(read->mol, *params) : std::string();
}

/// The test as replica "T" meshing a job: it holds the job's run lease (server/redis/redis_run_lease.hpp) from
/// construction to release(), so whichever replica takes the job follows T's run (redis_job_store::claim_run) and
/// stays running (cancellable, its record "running") instead of meshing. The lease outlives any test; release()
/// gives it up, and the follower then meshes the job itself.
class held_run {
 public:
  held_run(const tracemesh::server::redis_endpoint& redis, std::string job_id)
      : client_(redis, {}), lease_(client_, "T"), job_id_(std::move(job_id)) {
    const auto acquired = lease_.acquire(job_id_, std::chrono::minutes(30));
    EXPECT_TRUE(acquired.ok() && *acquired) << "could not hold the run lease of " << job_id_;
  }
  ~held_run() { release(); }
  held_run(const held_run&) = delete;
  held_run& operator=(const held_run&) = delete;

  void release() {
    if (released_) return;
    released_ = true;
    EXPECT_TRUE(lease_.release(job_id_).ok());
  }

 private:
  tracemesh::server::redis_client client_;
  tracemesh::server::redis_run_lease lease_;
  std::string job_id_;
  bool released_ = false;
};

class ReplicasTest : public ::testing::Test {
 protected:
  void SetUp() override {
    TRACEMESH_REQUIRE_REDIS_SERVER();
    ASSERT_TRUE(redis_.start());
    fs::create_directories(shared_dir());
  }

  fs::path shared_dir() const { return work_.path() / "shared"; }

  /// A replica named `name` on the shared Redis and result directory: one general worker, no small-job lane, one
  /// mesher thread, the short reclaim timeout.
  std::unique_ptr<server_process> start_replica(const std::string& name) {
    const fs::path dir = work_.path() / name;
    fs::create_directories(dir);
    return std::make_unique<server_process>(
        dir, std::vector<std::string>{"--cache-dir", shared_dir().string(), "--store", redis_.url(),
                                      "--replica-name", name, "--workers", "1", "--small-job-workers", "0",
                                      "--mesher-threads", "1", "--reclaim-timeout",
                                      std::to_string(std::chrono::duration<double>(reclaim_timeout).count()),
                                      "--shutdown-grace", "1"});
  }

  /// POST /jobs of `spec` to `port`: the reply document ({id, status, token, ...}); fails the test unless 202/200.
  nlohmann::json submit(unsigned short port, const job_spec& spec) {
    const http_reply reply =
        round_trip(port, tracemesh::testing::upload_request("/jobs", molecule(spec.molecule), spec.fields));
    EXPECT_TRUE(reply.status == 202 || reply.status == 200) << reply.status << " " << reply.body;
    return nlohmann::json::parse(reply.body, nullptr, false);
  }

  static http_reply get(unsigned short port, const std::string& target, const std::string& headers = {}) {
    return round_trip(port, tracemesh::testing::get_request(target, headers));
  }

  static nlohmann::json job(unsigned short port, const std::string& id) {
    const http_reply reply = get(port, "/jobs/" + id);
    return reply.status == 200 ? nlohmann::json::parse(reply.body, nullptr, false) : nlohmann::json();
  }

  /// Polls GET /jobs/{id} on `port` until the job is final: its document (null when it never was, within
  /// eventually()'s deadline).
  static nlohmann::json wait_final(unsigned short port, const std::string& id) {
    nlohmann::json doc;
    const bool final = eventually([&] {
      doc = job(port, id);
      const std::string status = doc.is_object() ? doc.value("status", "") : "";
      return status == "done" || status == "failed" || status == "cancelled";
    });
    return final ? doc : nlohmann::json(nullptr);
  }

  /// Waits until no replica on `ports` runs a job. A job's record says done as soon as its mesh is stored, a moment
  /// before the replica that ran it has finished it locally; until then that replica answers the job's /mesh with
  /// 409 "running".
  static bool nothing_running(const std::vector<unsigned short>& ports) {
    return eventually([&] {
      for (const unsigned short port : ports) {
        if (metric(port, "tracemesh_running_jobs") != 0) return false;
      }
      return true;
    });
  }

  /// held_run of the job of `spec`, on this test's Redis.
  std::unique_ptr<held_run> hold(const job_spec& spec) {
    return std::make_unique<held_run>(redis_.endpoint(), job_id_of(spec));
  }

  /// One sample of /metrics on `port` ("name{labels}" exactly as rendered); -1 when absent.
  static double metric(unsigned short port, const std::string& sample) {
    const http_reply reply = get(port, "/metrics");
    const auto at = reply.body.find("\n" + sample + " ");
    if (at == std::string::npos) return -1;
    return std::strtod(reply.body.c_str() + at + sample.size() + 2, nullptr);
  }

  static double jobs_run(unsigned short port, const std::string& replica, const char* how) {
    return metric(port, "tracemesh_replica_jobs_total{replica=\"" + replica + "\",how=\"" + how + "\"}");
  }

  /// The replica the record says runs job `id` (empty while none does).
  std::string running_on(const std::string& id) {
    tracemesh::server::redis_client client(redis_.endpoint(), {});
    const auto reply = client.command({"HMGET", "tracemesh:job:" + id, "state", "replica"});
    if (!reply.ok() || reply->elements.size() != 2 || reply->elements[0].text != "running") return {};
    return reply->elements[1].text;
  }

  tracemesh::testing::redis_process redis_{true};  // append-only file on, as in docker/compose.yaml
  temp_dir work_;
};

// 20 jobs of mixed molecules and parameters through nginx (docker/nginx's replicas upstream): both replicas take
// work from the shared stream (each ran at least one), every job ends done, and every mesh is served through nginx
// and by either replica. Then one replica is killed: nginx stops routing to it and every request still succeeds.
// The first job is held (held_run) until the other 19 are done: its replica's one worker stays busy, so the other
// replica must take work, however fast either meshes.
TEST_F(ReplicasTest, MixedJobsThroughNginxSpreadOverBothReplicasAndNginxSkipsADeadOne) {
  TRACEMESH_REQUIRE_NGINX();
  auto a = start_replica("A");
  auto b = start_replica("B");
  tracemesh::testing::nginx_process nginx(work_.path() / "nginx", {a->port(), b->port()});
  ASSERT_NE(nginx.port(), 0);
  const std::vector<std::string> molecules{"gly.pqr", "adp.pqr", "villin_1vii.pqr", "fas2.pqr"};
  const auto spec_of = [&](int i) {
    return job_spec{molecules[i % 4], {{"density", std::to_string(0.8 + 0.1 * (i / 4))}}};
  };
  const std::unique_ptr<held_run> first = hold(spec_of(0));
  std::vector<std::string> ids;
  for (int i = 0; i < 20; ++i) {
    const nlohmann::json accepted = submit(nginx.port(), spec_of(i));
    ASSERT_TRUE(accepted.contains("id")) << accepted;
    ids.push_back(accepted["id"]);
  }
  ASSERT_EQ(ids.front(), job_id_of(spec_of(0))) << "the held lease is not the first job's";
  ASSERT_TRUE(eventually([&] { return !running_on(ids.front()).empty(); })) << "no replica took the first job";
  const auto wait_done = [&](const std::string& id) {
    const nlohmann::json doc = wait_final(nginx.port(), id);
    ASSERT_TRUE(doc.is_object()) << "job " << id << " did not finish";
    EXPECT_EQ(doc["status"], "done") << doc.dump();
  };
  for (std::size_t i = 1; i < ids.size(); ++i) wait_done(ids[i]);
  first->release();
  wait_done(ids.front());
  ASSERT_TRUE(nothing_running({a->port(), b->port()}));
  const double ran_on_a = jobs_run(a->port(), "A", "taken");
  const double ran_on_b = jobs_run(b->port(), "B", "taken");
  std::cout << "[ spread   ] A ran " << ran_on_a << ", B ran " << ran_on_b << " of 20 jobs\n";
  EXPECT_GE(ran_on_a, 1) << "replica A ran no job";
  EXPECT_GE(ran_on_b, 1) << "replica B ran no job";
  EXPECT_EQ(ran_on_a + ran_on_b, 20);
  for (std::size_t i = 0; i < ids.size(); i += 5) {
    EXPECT_EQ(get(nginx.port(), "/jobs/" + ids[i] + "/mesh?format=off").status, 200);
    EXPECT_EQ(get(a->port(), "/jobs/" + ids[i] + "/mesh?format=ply").status, 200);
    EXPECT_EQ(get(b->port(), "/jobs/" + ids[i] + "/mesh?format=draco").status, 200);
  }

  b->kill(SIGKILL);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(get(nginx.port(), "/jobs/" + ids[i]).status, 200) << "request " << i << " after replica B died";
  }
  const nlohmann::json after = submit(nginx.port(), {"gly.pqr", {{"density", "3"}}});
  ASSERT_TRUE(after.contains("id"));
  const nlohmann::json doc = wait_final(nginx.port(), after["id"]);
  ASSERT_TRUE(doc.is_object());
  EXPECT_EQ(doc["status"], "done");
}

// The same molecule sent to both replicas at once, asynchronously and synchronously, is meshed once: the POST
// /jobs submissions share one job id and record, the /mesh requests wait on the run lease, and both replicas
// serve the same bytes.
TEST_F(ReplicasTest, SameMoleculeSentToBothReplicasIsMeshedOnce) {
  auto a = start_replica("A");
  auto b = start_replica("B");
  const job_spec spec{"fas2.pqr", {{"density", "2"}}};
  nlohmann::json from_a, from_b;
  http_reply mesh_a, mesh_b;
  {
    std::vector<std::thread> clients;
    clients.emplace_back([&] { from_a = submit(a->port(), spec); });
    clients.emplace_back([&] { from_b = submit(b->port(), spec); });
    clients.emplace_back([&] {
      mesh_a = round_trip(a->port(), tracemesh::testing::upload_request("/mesh", molecule(spec.molecule), spec.fields));
    });
    clients.emplace_back([&] {
      mesh_b = round_trip(b->port(), tracemesh::testing::upload_request("/mesh", molecule(spec.molecule), spec.fields));
    });
    for (std::thread& client : clients) client.join();
  }
  ASSERT_EQ(from_a["id"], from_b["id"]);
  EXPECT_NE(from_a["token"], from_b["token"]) << "each submission gets its own owner token";
  ASSERT_EQ(mesh_a.status, 200) << mesh_a.body;
  ASSERT_EQ(mesh_b.status, 200) << mesh_b.body;
  EXPECT_EQ(mesh_a.body, mesh_b.body);
  const nlohmann::json doc = wait_final(a->port(), from_a["id"]);
  ASSERT_TRUE(doc.is_object());
  EXPECT_EQ(doc["status"], "done");
  EXPECT_EQ(metric(a->port(), "tracemesh_mesher_runs_total") + metric(b->port(), "tracemesh_mesher_runs_total"), 1)
      << "the molecule was meshed more than once";
}

// A job created through replica A is read, streamed and cancelled through replica B with its owner token. The job
// is held (held_run): it is still running when the cancel arrives, however fast the machine.
TEST_F(ReplicasTest, JobCreatedThroughOneReplicaIsReadStreamedAndCancelledThroughAnother) {
  auto a = start_replica("A");
  auto b = start_replica("B");
  const job_spec spec{"villin_1vii.pqr", {{"density", "2"}}};
  const std::unique_ptr<held_run> held = hold(spec);
  const nlohmann::json accepted = submit(a->port(), spec);
  const std::string id = accepted["id"];
  const std::string token = accepted["token"];
  ASSERT_EQ(id, job_id_of(spec)) << "the held lease is not this job's";
  ASSERT_TRUE(eventually([&] { return !running_on(id).empty(); })) << "no replica took the job";

  const nlohmann::json through_b = job(b->port(), id);
  ASSERT_TRUE(through_b.is_object());
  EXPECT_EQ(through_b["id"], id);
  EXPECT_EQ(through_b["status"], "running");

  tracemesh::testing::raw_connection stream(b->port());
  ASSERT_TRUE(stream.send(tracemesh::testing::get_request("/jobs/" + id + "/events")));
  const auto events = [&] { return tracemesh::testing::parse_raw_event_stream(stream.unread()); };
  ASSERT_TRUE(eventually([&] { return !events().events.empty() || stream.closed_by_peer(1ms); }));
  ASSERT_FALSE(events().events.empty()) << stream.unread();
  EXPECT_EQ(events().events.front().name, "progress") << "the stream through B starts with the job's progress";
  EXPECT_EQ(round_trip(b->port(), "DELETE /jobs/" + id + " HTTP/1.1\r\nHost: t\r\n\r\n").status, 401);
  EXPECT_EQ(round_trip(b->port(), "DELETE /jobs/" + id + " HTTP/1.1\r\nHost: t\r\nX-Job-Token: " +
                                      std::string(64, 'f') + "\r\n\r\n")
                .status,
            403);
  const http_reply cancelled =
      round_trip(b->port(), "DELETE /jobs/" + id + " HTTP/1.1\r\nHost: t\r\nX-Job-Token: " + token + "\r\n\r\n");
  EXPECT_EQ(cancelled.status, 200) << cancelled.body;
  ASSERT_TRUE(stream.closed_by_peer()) << "the stream through B did not end";

  const tracemesh::testing::raw_event_stream sse = events();
  EXPECT_EQ(sse.headers.count(":status") ? sse.headers.at(":status") : "", "200");
  ASSERT_GE(sse.events.size(), 2u) << stream.unread();
  EXPECT_EQ(sse.events.front().name, "progress");
  EXPECT_EQ(sse.events.back().name, "error") << "the stream through B ends with the cancellation";
  const nlohmann::json final_doc = wait_final(a->port(), id);
  ASSERT_TRUE(final_doc.is_object());
  EXPECT_EQ(final_doc["status"], "cancelled");
  EXPECT_EQ(job(b->port(), id)["status"], "cancelled");
}

// kill -9 of the replica running a job: another replica reclaims it after the reclaim timeout, meshes it, and
// serves its mesh. The job is held (held_run) until the kill, so it is still running on the victim, however fast
// the machine.
TEST_F(ReplicasTest, JobOfAKilledReplicaCompletesOnAnotherAndItsMeshIsServed) {
  std::map<std::string, std::unique_ptr<server_process>> replicas;
  replicas["A"] = start_replica("A");
  replicas["B"] = start_replica("B");
  const job_spec spec{"fas2.pqr", {{"density", "2"}}};
  const std::unique_ptr<held_run> held = hold(spec);
  const nlohmann::json accepted = submit(replicas["A"]->port(), spec);
  const std::string id = accepted["id"];
  ASSERT_EQ(id, job_id_of(spec)) << "the held lease is not this job's";
  std::string victim;
  ASSERT_TRUE(eventually([&] { return !(victim = running_on(id)).empty(); }));
  const std::string survivor = victim == "A" ? "B" : "A";
  const auto killed_at = std::chrono::steady_clock::now();
  replicas[victim]->kill(SIGKILL);
  held->release();
  const unsigned short port = replicas[survivor]->port();

  const nlohmann::json doc = wait_final(port, id);
  ASSERT_TRUE(doc.is_object()) << "the job did not finish on " << survivor;
  EXPECT_EQ(doc["status"], "done") << doc.dump();
  std::cout << "[ reclaim  ] done on " << survivor << " "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - killed_at).count()
            << " s after kill -9 of " << victim << "\n";
  EXPECT_EQ(jobs_run(port, survivor, "reclaimed"), 1);
  ASSERT_TRUE(nothing_running({port}));
  const http_reply mesh = get(port, "/jobs/" + id + "/mesh?format=off");
  EXPECT_EQ(mesh.status, 200) << mesh.body.substr(0, 300) << "\n" << replicas[survivor]->log();
  EXPECT_EQ(mesh.body.rfind("OFF", 0), 0u);
}

// Redis killed and restarted (append-only file) while jobs are queued and running: /readyz says so on every replica
// meanwhile, the replicas reconnect, and every job answered 202 ends done.
TEST_F(ReplicasTest, RedisRestartLosesNoAcceptedJob) {
  auto a = start_replica("A");
  auto b = start_replica("B");
  std::vector<std::string> ids;
  for (int i = 0; i < 6; ++i) {
    const job_spec spec{i % 2 == 0 ? "villin_1vii.pqr" : "fas2.pqr", {{"density", std::to_string(1 + i)}}};
    ids.push_back(submit(i % 2 == 0 ? a->port() : b->port(), spec)["id"]);
  }
  redis_.stop();
  for (server_process* replica : {a.get(), b.get()}) {
    EXPECT_TRUE(eventually([&] { return get(replica->port(), "/readyz").status == 503; }))
        << "/readyz stayed ready without Redis";
  }
  const http_reply refused =
      round_trip(a->port(), tracemesh::testing::upload_request("/jobs", molecule("gly.pqr"), {{"density", "3"}}));
  EXPECT_EQ(refused.status, 503) << "a job that cannot be recorded is not accepted";
  EXPECT_EQ(get(a->port(), "/healthz").status, 200) << "alive without Redis";
  // Jobs already taken run on (and may finish) while Redis is away; nothing below depends on how far they got.
  ASSERT_TRUE(redis_.restart());
  for (server_process* replica : {a.get(), b.get()}) {
    EXPECT_TRUE(eventually([&] { return get(replica->port(), "/readyz").status == 200; }))
        << "a replica did not reconnect";
  }
  for (const std::string& id : ids) {
    const nlohmann::json doc = wait_final(a->port(), id);
    ASSERT_TRUE(doc.is_object()) << "job " << id << " was lost or never finished";
    EXPECT_EQ(doc["status"], "done") << doc.dump();
  }
}

}  // namespace
