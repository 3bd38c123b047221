// End-to-end tests of the tracemeshd binary: the real server with the real mesher on a loopback port and a
// temporary cache directory, talked to with curl (as a scientist would) and decoded with Debian's draco_decoder.
// Molecules are the small ones of the shared ladder (gly, adp, villin, fas2) so the suite stays fast.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/analysis/mesh_analysis.hpp"
#include "server/storage/job_store.hpp"
#include "server/storage/result_cache.hpp"
#include "support/delivered_mesh.hpp"
#include "support/event_stream.hpp"
#include "support/eventually.hpp"
#include "support/pqr_edits.hpp"
#include "support/sanitized_build.hpp"
#include "support/shell_xyzr.hpp"
#include "support/structure_writers.hpp"
#include "support/test_http_client.hpp"
#include "support/test_paths.hpp"
#include "support/tracemeshd_process.hpp"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using tracemesh::testing::binary_path;
using tracemesh::testing::eventually;
using tracemesh::testing::held_jobs;
using tracemesh::testing::molecule_path;
using tracemesh::testing::open_gate;
using tracemesh::testing::read_file;
using tracemesh::testing::server_process;
using tracemesh::testing::temp_dir;

/// Runs a shell command; returns its standard output (trailing newline kept).
std::string run(const std::string& command) {
  std::string out;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buffer;
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  ::pclose(pipe);
  return out;
}

/// A curl reply: status, headers (lower-case names) and the body saved in a file.
struct curl_reply {
  int status = 0;
  std::map<std::string, std::string> headers;
  std::string body;
};

class TracemeshdTest : public ::testing::Test {
 protected:
  /// `curl <args> <url>`, saving headers and body under the work dir.
  curl_reply curl(const std::string& args, const std::string& url) {
    const std::string tag = std::to_string(calls_++);
    const fs::path headers = work_.path() / ("headers" + tag);
    const fs::path body = work_.path() / ("body" + tag);
    const std::string code = run(std::string(TRACEMESH_CURL) + " -s -S -o " + body.string() + " -D " +
                                 headers.string() + " -w '%{http_code}' " + args + " '" + url + "'");
    curl_reply reply;
    reply.status = code.empty() ? 0 : std::atoi(code.c_str());
    std::istringstream lines(read_file(headers));
    std::string line;
    while (std::getline(lines, line)) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      const auto colon = line.find(':');
      if (colon == std::string::npos) continue;
      std::string name = line.substr(0, colon);
      for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      reply.headers[name] = line.substr(line.find_first_not_of(' ', colon + 1));
    }
    reply.body = read_file(body);
    record_json_exchange(args, url, reply);
    return reply;
  }

  /// Every JSON body received is kept (with its method, path and status) and checked at the end of the test against
  /// the schema that openapi.json gives for it, with Ajv (tests/node/check_openapi.mjs).
  void record_json_exchange(const std::string& args, const std::string& url, const curl_reply& reply) {
    const auto type = reply.headers.find("content-type");
    if (type == reply.headers.end() || type->second.rfind("application/json", 0) != 0) return;
    const std::string method = args.find("-X DELETE") != std::string::npos ? "delete"
                               : args.find("-F ") != std::string::npos || args.find("--data") != std::string::npos
                                   ? "post"
                                   : "get";
    std::string path = url.substr(url.find('/', std::string("http://").size()));
    path = path.substr(0, path.find('?'));
    const nlohmann::json record = {{"method", method}, {"path", path}, {"status", reply.status}, {"body", reply.body}};
    std::ofstream(work_.path() / "exchanges.jsonl", std::ios::app) << record.dump() << "\n";
  }

  void TearDown() override {
    const fs::path exchanges = work_.path() / "exchanges.jsonl";
    if (!fs::exists(exchanges)) return;
    std::string command = TRACEMESH_NODE;
    command.append(" ").append(TRACEMESH_SOURCE_DIR).append("/tests/node/check_openapi.mjs bodies ");
    command.append(TRACEMESH_SOURCE_DIR).append("/proto/openapi.json ").append(exchanges.string());
    command.append(" 2>&1; echo \"exit=$?\"");
    const std::string out = run(command);
    EXPECT_NE(out.find("exit=0"), std::string::npos) << "JSON bodies against openapi.json:\n" << out;
  }

  /// Uploads `file` as the field `pqr` (which declares PQR) when it is a .pqr file, else as `structure`.
  curl_reply upload(const server_process& server, const fs::path& file, const std::string& fields = {},
                    const std::string& route = "/mesh") {
    const std::string name = file.filename().string();
    const bool pqr = name.ends_with(".pqr") || name.ends_with(".pqr.gz");
    return curl(std::string(pqr ? "-F pqr=@" : "-F structure=@") + file.string() + " " + fields, server.url(route));
  }

  /// The value of an unlabelled sample in /metrics.
  double metric(const server_process& server, const std::string& name) {
    std::istringstream lines(curl("", server.url("/metrics")).body);
    std::string line;
    while (std::getline(lines, line)) {
      if (line.rfind(name + " ", 0) == 0) return std::stod(line.substr(name.size() + 1));
    }
    return -1;
  }

  /// Jobs of at least `min_atoms` atoms, held by the server until open_gate() (support/held_jobs.hpp): running,
  /// cancellable, but not meshing. A test that acts on a running job holds it, so no mesher is too fast for it.
  held_jobs hold_jobs(std::size_t min_atoms = 0) const { return held_jobs{work_.path() / "gate", min_atoms}; }

  /// Waits until `server` runs at least `jobs` jobs (a worker took them); false only at eventually()'s deadline.
  bool jobs_running(const server_process& server, double jobs = 1) {
    return eventually([&] { return metric(server, "tracemesh_running_jobs") >= jobs; });
  }

  void expect_error(const curl_reply& reply, int status, const std::string& code, const std::string& what) {
    EXPECT_EQ(reply.status, status) << what << ": " << reply.body;
    const auto doc = nlohmann::json::parse(reply.body, nullptr, false);
    ASSERT_FALSE(doc.is_discarded()) << what << ": " << reply.body;
    EXPECT_EQ(doc["error"]["code"], code) << what << ": " << reply.body;
  }

  /// Vertex and triangle counts from an OFF header.
  static std::pair<long, long> off_counts(const std::string& off) {
    std::istringstream in(off);
    std::string magic;
    long vertices = -1, triangles = -1;
    in >> magic >> vertices >> triangles;
    return {vertices, triangles};
  }

  /// Temporary files (the cache's ".tmp-" prefix) anywhere under `dir`.
  static std::vector<std::string> temporary_files(const fs::path& dir) {
    std::vector<std::string> found;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
      if (entry.path().filename().string().rfind(".tmp-", 0) == 0) found.push_back(entry.path().string());
    }
    return found;
  }

  /// POST /jobs, then polls GET /jobs/{id} until the job is final; the final document (or {"http": status}).
  nlohmann::json run_job(const server_process& server, const fs::path& pqr, const std::string& fields,
                         const std::string& query = {}) {
    curl_reply accepted = upload(server, pqr, fields, "/jobs" + query);
    if (accepted.status != 202 && accepted.status != 200) return {{"http", accepted.status}, {"body", accepted.body}};
    const std::string id = nlohmann::json::parse(accepted.body).at("id");
    const auto deadline = std::chrono::steady_clock::now() + 300s;
    for (;;) {
      curl_reply polled = curl("", server.url("/jobs/" + id));
      if (polled.status != 200) return {{"http", polled.status}, {"body", polled.body}};
      nlohmann::json doc = nlohmann::json::parse(polled.body);
      const std::string state = doc.at("status");
      if (state == "done" || state == "failed" || state == "cancelled") return doc;
      if (std::chrono::steady_clock::now() > deadline) return {{"timeout", true}, {"last", doc}};
      std::this_thread::sleep_for(20ms);
    }
  }

  /// Checks a done job's certified report against its OFF mesh (fetched by id); returns the report.
  nlohmann::json expect_certified_job(const server_process& server, const nlohmann::json& job) {
    EXPECT_EQ(job.value("status", ""), "done") << job;
    if (job.value("status", "") != "done") return nlohmann::json::object();
    const nlohmann::json& report = job.at("report");
    EXPECT_EQ(report.at("certificate").at("certified"), true) << report.at("certificate");
    curl_reply mesh = curl("", server.url("/jobs/" + job.at("id").get<std::string>() + "/mesh?format=off"));
    EXPECT_EQ(mesh.status, 200);
    const auto [vertices, triangles] = off_counts(mesh.body);
    EXPECT_EQ(report.at("vertices"), vertices);
    EXPECT_EQ(report.at("triangles"), triangles);
    return report;
  }

  fs::path write(const std::string& name, const std::string& content) {
    const fs::path path = work_.path() / name;
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }

  temp_dir work_;
  temp_dir cache_;
  std::atomic<int> calls_{0};  // curl() runs on several threads in some tests
};

TEST_F(TracemeshdTest, OffAndDracoRoundTripsOnRealMolecules) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  for (const char* name : {"gly.pqr", "adp.pqr", "villin_1vii.pqr"}) {
    curl_reply off = upload(server, molecule_path(name));
    ASSERT_EQ(off.status, 200) << name << ": " << off.body;
    EXPECT_EQ(off.headers["x-cache"], "miss") << name;
    const auto [vertices, triangles] = off_counts(off.body);
    EXPECT_GT(vertices, 0) << name;
    EXPECT_GT(triangles, vertices) << name;

    curl_reply draco = upload(server, molecule_path(name), "-F format=draco");
    ASSERT_EQ(draco.status, 200) << name;
    EXPECT_EQ(draco.headers["x-cache"], "hit") << name << ": the job cached both encodings";
    EXPECT_EQ(draco.headers["x-job-id"], off.headers["x-job-id"]);
    const fs::path drc = write(std::string(name) + ".drc", draco.body);
    const fs::path obj = work_.path() / (std::string(name) + ".obj");
    run(std::string(TRACEMESH_DRACO_DECODER) + " -i " + drc.string() + " -o " + obj.string() + " > /dev/null");
    std::istringstream decoded(read_file(obj));
    long decoded_vertices = 0, decoded_faces = 0;
    std::string line;
    while (std::getline(decoded, line)) {
      if (line.rfind("v ", 0) == 0) ++decoded_vertices;
      if (line.rfind("f ", 0) == 0) ++decoded_faces;
    }
    EXPECT_EQ(decoded_vertices, vertices) << name;
    EXPECT_EQ(decoded_faces, triangles) << name;
  }
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 3);
}

TEST_F(TracemeshdTest, LatticeMethodWithAndWithoutRefinementGivesCertifiedMeshes) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string(), "--workers", "2"});
  for (const char* name : {"gly.pqr", "fas2.pqr"}) {
    std::map<std::string, std::string> ids;
    std::map<std::string, long> vertices;
    for (const char* refine : {"none", "full"}) {
      SCOPED_TRACE(std::string(name) + " refine " + refine);
      // Form fields on POST /jobs.
      const nlohmann::json job =
          run_job(server, molecule_path(name), std::string("-F method=lattice -F refine=") + refine);
      const nlohmann::json report = expect_certified_job(server, job);
      if (report.empty()) continue;
      EXPECT_EQ(report.at("method"), "lattice");
      EXPECT_EQ(report.at("refine"), refine);
      EXPECT_TRUE(report.at("trace").is_null());
      EXPECT_EQ(report.at("timings").contains("refining"), std::string(refine) == "full") << report.at("timings");
      ids[refine] = job.at("id");
      vertices[refine] = report.at("vertices");
      // Query parameters on POST /mesh: the same job, served from the cache.
      curl_reply sync = curl("-F pqr=@" + molecule_path(name).string(),
                             server.url(std::string("/mesh?method=lattice&refine=") + refine));
      EXPECT_EQ(sync.status, 200) << sync.body;
      EXPECT_EQ(sync.headers["x-job-id"], ids[refine]);
      EXPECT_EQ(sync.headers["x-cache"], "hit");
    }
    EXPECT_NE(ids["none"], ids["full"]) << name << ": refine makes another job";
    EXPECT_GT(vertices["none"], vertices["full"]) << name;
  }
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 4);
}

// A job the trace path cannot close on any line grid (mache with a sharp kernel, tests/core/mesher_test.cpp) is done,
// not failed: the lattice path's certified mesh, a report that says so, and counters an operator can alert on.
TEST_F(TracemeshdTest, ATraceJobThatFallsBackIsDoneReportedAndCounted) {
  // Release suite only: the job (three line grids, then the lattice path) takes minutes under a sanitizer, and
  // mesher_fallback in tests/core/mesher_test.cpp runs it there. What this test adds is bookkeeping:
  // the report's fields and two counters.
  if (tracemesh::testing::sanitized_build()) {
    GTEST_SKIP() << "Release suite only: core mesher_fallback runs this job under the sanitizers";
  }
  server_process server(work_.path(), {});
  EXPECT_EQ(metric(server, "tracemesh_trace_fallbacks_total"), 0);
  EXPECT_EQ(metric(server, "tracemesh_trace_grid_retries_total"), 0);
  const nlohmann::json job =
      run_job(server, molecule_path("mache.pqr"), "-F method=trace -F d=-20 -F t0=3 -F density=0.1");
  const nlohmann::json report = expect_certified_job(server, job);
  ASSERT_FALSE(report.empty());
  EXPECT_EQ(report.at("method"), "trace");
  EXPECT_EQ(report.at("method_used"), "lattice");
  EXPECT_TRUE(report.at("fallback").is_string()) << report;
  EXPECT_TRUE(report.at("trace").is_null());
  EXPECT_EQ(metric(server, "tracemesh_trace_fallbacks_total"), 1);
  EXPECT_EQ(metric(server, "tracemesh_trace_grid_retries_total"), 2);
  const nlohmann::json plain = run_job(server, molecule_path("gly.pqr"), "");
  const nlohmann::json plain_report = expect_certified_job(server, plain);
  ASSERT_FALSE(plain_report.empty());
  EXPECT_EQ(plain_report.at("method_used"), plain_report.at("method"));
  EXPECT_TRUE(plain_report.at("fallback").is_null());
  EXPECT_EQ(metric(server, "tracemesh_trace_fallbacks_total"), 1);
}

TEST_F(TracemeshdTest, MethodAndRefineAreDifferentJobsAndSpelledOutDefaultsTheSameJob) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const fs::path gly = molecule_path("gly.pqr");
  curl_reply implicit = upload(server, gly);
  ASSERT_EQ(implicit.status, 200) << implicit.body;
  const std::string id = implicit.headers["x-job-id"];
  const nlohmann::json defaults = nlohmann::json::parse(curl("", server.url("/jobs/" + id)).body).at("report");
  const std::string method = defaults.at("method"), refine = defaults.at("refine");
  // Every default spelled out, as form fields and as query parameters: the same job, a cache hit.
  const std::string spelled = "method=" + method + "&refine=" + refine +
                              "&density=1.0&d=-1&t0=1&trace_degree=10&trace_step=0.5&trace_cos_bound=0.9396926207859084"
                              "&trace_extreme_tolerance=0.02";
  curl_reply as_query = curl("-F pqr=@" + gly.string(), server.url("/mesh?" + spelled));
  EXPECT_EQ(as_query.headers["x-job-id"], id) << as_query.body;
  EXPECT_EQ(as_query.headers["x-cache"], "hit");
  std::string form;
  std::istringstream pairs(spelled);
  for (std::string pair; std::getline(pairs, pair, '&');) form += " -F " + pair;
  curl_reply as_form = upload(server, gly, form);
  EXPECT_EQ(as_form.headers["x-job-id"], id) << as_form.body;
  EXPECT_EQ(as_form.body, implicit.body);
  // The other method and the other refine mode are other jobs.
  const std::string other_method = method == "trace" ? "lattice" : "trace";
  const std::string other_refine = refine == "full" ? "none" : "full";
  curl_reply by_refine = upload(server, gly, "-F refine=" + other_refine);
  EXPECT_EQ(by_refine.status, 200) << by_refine.body;
  EXPECT_NE(by_refine.headers["x-job-id"], id);
  curl_reply by_method = upload(server, gly, "-F method=" + other_method);
  EXPECT_NE(by_method.headers["x-job-id"], id) << by_method.body;
  EXPECT_NE(by_method.headers["x-job-id"], by_refine.headers["x-job-id"]);
}

TEST_F(TracemeshdTest, BadMethodRefineAndTraceParametersGet400NamingThem) {
  server_process server(work_.path(), {});
  const fs::path gly = molecule_path("gly.pqr");
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"method", "Trace"},         {"refine", "partial"},          {"trace_degree", "2.5"},
      {"trace_degree", "100"},     {"trace_step", "0"},            {"trace_cos_bound", "1"},
      {"trace_extreme_tolerance", "0.5"}};
  for (const auto& [name, value] : bad) {
    for (const char* route : {"/mesh", "/jobs"}) {
      curl_reply as_form = upload(server, gly, "-F " + name + "=" + value, route);
      expect_error(as_form, 400, "invalid_argument", name + " as a form field on " + route);
      EXPECT_EQ(nlohmann::json::parse(as_form.body)["error"]["message"].get<std::string>().rfind(name, 0), 0u)
          << as_form.body;
      curl_reply as_query = upload(server, gly, "", std::string(route) + "?" + name + "=" + value);
      expect_error(as_query, 400, "invalid_argument", name + " as a query parameter on " + route);
      EXPECT_EQ(nlohmann::json::parse(as_query.body)["error"]["message"].get<std::string>().rfind(name, 0), 0u)
          << as_query.body;
    }
  }
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 0);
}

// The trace method end to end on real molecules: certified meshes and the trace section of the report.
TEST_F(TracemeshdTest, TraceMethodGivesCertifiedMeshesWithTraceReports) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string(), "--workers", "2"});
  for (const char* name : {"gly.pqr", "fas2.pqr"}) {
    std::map<std::string, std::string> ids;
    for (const char* refine : {"none", "full"}) {
      SCOPED_TRACE(std::string(name) + " refine " + refine);
      const nlohmann::json job =
          run_job(server, molecule_path(name), "", std::string("?method=trace&refine=") + refine);
      const nlohmann::json report = expect_certified_job(server, job);
      if (report.empty()) continue;
      ids[refine] = job.at("id");
      EXPECT_EQ(report.at("method"), "trace");
      EXPECT_EQ(report.at("refine"), refine);
      const nlohmann::json& trace = report.at("trace");
      ASSERT_TRUE(trace.is_object()) << report;
      EXPECT_GT(trace.at("lines").get<double>(), 0);
      EXPECT_GT(trace.at("polygons").get<double>(), 0);
      EXPECT_GT(trace.at("raw_vertices").get<double>(), 0);
      EXPECT_GT(trace.at("field_evaluations_per_vertex").get<double>(), 0);
      EXPECT_TRUE(trace.contains("fallback_loops"));
      EXPECT_TRUE(trace.at("fallback_loops").is_number_unsigned());
      EXPECT_GT(trace.at("parameters").at("line_spacing").get<double>(), 0);
      EXPECT_GT(trace.at("parameters").at("step").get<double>(), 0);
      EXPECT_TRUE(report.at("timings").contains("tracing")) << report.at("timings");
      // The same request as form fields is the same job (a hit), and the lattice method another one.
      curl_reply again = upload(server, molecule_path(name), std::string("-F method=trace -F refine=") + refine);
      EXPECT_EQ(again.status, 200) << again.body;
      EXPECT_EQ(again.headers["x-job-id"], ids[refine]);
      EXPECT_EQ(again.headers["x-cache"], "hit");
    }
    EXPECT_NE(ids["none"], ids["full"]) << name;
  }
}

TEST_F(TracemeshdTest, TraceMethodParametersReachTheEngineAndItsReport) {
  server_process server(work_.path(), {});
  const nlohmann::json job = run_job(server, molecule_path("gly.pqr"),
                                     "-F method=trace -F trace_degree=12 -F trace_step=0.25 -F trace_cos_bound=0.95 "
                                     "-F trace_extreme_tolerance=0.01");
  const nlohmann::json report = expect_certified_job(server, job);
  ASSERT_FALSE(report.empty());
  const nlohmann::json& parameters = report.at("trace").at("parameters");
  EXPECT_EQ(parameters.at("legendre_degree"), 12);
  EXPECT_EQ(parameters.at("step_fraction"), 0.25);
  EXPECT_EQ(parameters.at("cos_bound"), 0.95);
  EXPECT_EQ(parameters.at("extreme_tolerance"), 0.01);
  EXPECT_DOUBLE_EQ(parameters.at("step").get<double>(), 0.25 * parameters.at("line_spacing").get<double>());
  const nlohmann::json defaults = run_job(server, molecule_path("gly.pqr"), "-F method=trace");
  EXPECT_NE(defaults.value("id", ""), job.value("id", "")) << "trace parameters are part of a trace job";
}

TEST_F(TracemeshdTest, CacheHitsOnTheSecondRequestAndAfterARestart) {
  const fs::path gly = molecule_path("gly.pqr");
  std::string first_body, etag;
  {
    server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
    curl_reply first = upload(server, gly, "-F density=2");
    ASSERT_EQ(first.status, 200) << first.body;
    EXPECT_EQ(first.headers["x-cache"], "miss");
    curl_reply second = upload(server, gly, "-F density=2");
    EXPECT_EQ(second.headers["x-cache"], "hit");
    EXPECT_EQ(second.body, first.body);
    first_body = first.body;
    etag = first.headers["etag"];
    // A gzipped upload of the same atoms is the same job.
    run("gzip -c " + gly.string() + " > " + (work_.path() / "gly.pqr.gz").string());
    curl_reply gzipped = upload(server, work_.path() / "gly.pqr.gz", "-F density=2.0");
    EXPECT_EQ(gzipped.headers["x-cache"], "hit");
    EXPECT_EQ(gzipped.headers["x-job-id"], first.headers["x-job-id"]);
    EXPECT_EQ(server.kill(SIGTERM), 0);
  }
  server_process restarted(work_.path(), {"--cache-dir", cache_.path().string()});
  curl_reply after = upload(restarted, gly, "-F density=2");
  ASSERT_EQ(after.status, 200);
  EXPECT_EQ(after.headers["x-cache"], "hit");
  EXPECT_EQ(after.body, first_body);
  EXPECT_EQ(after.headers["etag"], etag);
  curl_reply revalidated = curl("-H 'If-None-Match: " + etag + "'",
                                      restarted.url("/jobs/" + after.headers["x-job-id"] + "/mesh"));
  EXPECT_EQ(revalidated.status, 304);
  EXPECT_EQ(metric(restarted, "tracemesh_mesher_runs_total"), 0);
}

// Issue 11 item 6, the wire: negotiated gzip/br (compressed once, cached as <id>.<format>.gz/.br), byte ranges of the
// selected representation, If-Range, 416, 406, HEAD, a resumed download (curl -C -), compressed JSON.
TEST_F(TracemeshdTest, CompressedAndRangedMeshDownloadsDecodeToTheIdentityBytes) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const nlohmann::json job = run_job(server, molecule_path("fas2.pqr"), "-F density=1");
  ASSERT_EQ(job.value("status", ""), "done") << job;
  const std::string id = job.at("id");
  const std::string url = server.url("/jobs/" + id + "/mesh?format=off");
  const curl_reply identity = curl("", url);
  ASSERT_EQ(identity.status, 200);
  EXPECT_EQ(identity.headers.count("content-encoding"), 0u);
  EXPECT_EQ(identity.headers.at("vary"), "Accept-Encoding");
  EXPECT_EQ(identity.headers.at("accept-ranges"), "bytes");
  EXPECT_EQ(std::stoul(identity.headers.at("content-length")), identity.body.size());

  // br and gzip: raw bytes with their own Content-Length and ETag; decoded (by curl, and by gzip -dc) they are the
  // identity bytes exactly.
  std::map<std::string, std::string> raw;
  for (const std::string coding : {"br", "gzip"}) {
    const curl_reply coded = curl("-H 'Accept-Encoding: " + coding + "'", url);
    ASSERT_EQ(coded.status, 200) << coding;
    EXPECT_EQ(coded.headers.at("content-encoding"), coding);
    EXPECT_EQ(coded.headers.at("vary"), "Accept-Encoding");
    EXPECT_EQ(coded.headers.at("x-cache"), "miss") << coding << ": compressed on first request";
    EXPECT_EQ(std::stoul(coded.headers.at("content-length")), coded.body.size());
    EXPECT_LT(coded.body.size(), identity.body.size() / 2) << coding;
    EXPECT_NE(coded.headers.at("etag"), identity.headers.at("etag"));
    raw[coding] = coded.body;
    const curl_reply decoded = curl("--compressed -H 'Accept-Encoding: " + coding + "'", url);
    EXPECT_EQ(decoded.headers.at("content-encoding"), coding);
    EXPECT_TRUE(decoded.body == identity.body) << coding << " does not decode to the identity bytes";
  }
  const fs::path gz = write("mesh.off.gz", raw.at("gzip"));
  EXPECT_TRUE(run("gzip -dc " + gz.string()) == identity.body);
  EXPECT_NE(curl("-H 'Accept-Encoding: br'", url).headers.at("etag"),
            curl("-H 'Accept-Encoding: gzip'", url).headers.at("etag"));

  // Compressed once: the cache holds <id>.off.br<level, version> and .gz<...> next to <id>.off, and later requests
  // are hits with the same bytes.
  std::vector<std::string> stored;
  for (const auto& entry : fs::directory_iterator(cache_.path() / id.substr(0, 2))) {
    stored.push_back(entry.path().filename().string().substr(id.size()));
  }
  std::sort(stored.begin(), stored.end());
  ASSERT_EQ(stored.size(), 3u) << ::testing::PrintToString(stored);
  EXPECT_EQ(stored[0], ".off");
  EXPECT_EQ(stored[1].rfind(".off.br4w22_b", 0), 0u) << stored[1];
  EXPECT_EQ(stored[2].rfind(".off.gz6_z", 0), 0u) << stored[2];
  const curl_reply again = curl("-H 'Accept-Encoding: gzip;q=0.5, br;q=0.9, identity;q=0.1'", url);
  EXPECT_EQ(again.headers.at("content-encoding"), "br");
  EXPECT_EQ(again.headers.at("x-cache"), "hit");
  EXPECT_TRUE(again.body == raw.at("br"));
  EXPECT_EQ(metric(server, "tracemesh_mesh_compressions_total{coding=\"br\"}"), 1);
  EXPECT_EQ(metric(server, "tracemesh_mesh_compressions_total{coding=\"gzip\"}"), 1);

  // HEAD: the GET's headers, the selected representation's length.
  const curl_reply head = curl("-I -H 'Accept-Encoding: br'", url);
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.headers.at("content-encoding"), "br");
  EXPECT_EQ(std::stoul(head.headers.at("content-length")), raw.at("br").size());

  // Ranges apply to the selected (compressed) bytes; the parts concatenate to the whole.
  const std::string& br = raw.at("br");
  const std::size_t cut = br.size() / 3;
  const curl_reply first = curl("-H 'Accept-Encoding: br' -r 0-" + std::to_string(cut - 1), url);
  const curl_reply rest = curl("-H 'Accept-Encoding: br' -r " + std::to_string(cut) + "-", url);
  ASSERT_EQ(first.status, 206);
  ASSERT_EQ(rest.status, 206);
  EXPECT_EQ(first.headers.at("content-range"), "bytes 0-" + std::to_string(cut - 1) + "/" + std::to_string(br.size()));
  EXPECT_EQ(std::stoul(first.headers.at("content-length")), cut);
  EXPECT_EQ(first.headers.at("content-encoding"), "br");
  EXPECT_TRUE(first.body + rest.body == br);
  const curl_reply suffix = curl("-r -100", url);
  EXPECT_EQ(suffix.status, 206);
  EXPECT_TRUE(suffix.body == identity.body.substr(identity.body.size() - 100));

  const std::string size = std::to_string(identity.body.size());
  const curl_reply past_end = curl("-r " + size + "-", url);
  EXPECT_EQ(past_end.status, 416);
  EXPECT_EQ(past_end.headers.at("content-range"), "bytes */" + size);
  // If-Range: the same ETag gives the range, another (or a weak one) the whole 200; several ranges: the whole.
  const std::string etag = identity.headers.at("etag");
  EXPECT_EQ(curl("-r 0-9 -H 'If-Range: " + etag + "'", url).status, 206);
  const curl_reply changed = curl("-r 0-9 -H 'If-Range: \"0-off\"'", url);
  EXPECT_EQ(changed.status, 200);
  EXPECT_TRUE(changed.body == identity.body);
  EXPECT_EQ(curl("-r 0-9 -H 'If-Range: W/" + etag + "'", url).status, 200);
  const curl_reply several = curl("-r 0-9,20-29", url);
  EXPECT_EQ(several.status, 200);
  EXPECT_TRUE(several.body == identity.body);

  // A download cut short is resumed with curl -C -: the file ends up whole.
  const fs::path partial = write("resumed.off", identity.body.substr(0, identity.body.size() / 2));
  run(std::string(TRACEMESH_CURL) + " -s -S -C - -o " + partial.string() + " '" + url + "'");
  EXPECT_TRUE(read_file(partial) == identity.body);

  // Draco is never compressed; refusing identity for it is 406.
  const curl_reply draco = curl("-H 'Accept-Encoding: br, gzip'", server.url("/jobs/" + id + "/mesh?format=draco"));
  EXPECT_EQ(draco.status, 200);
  EXPECT_EQ(draco.headers.count("content-encoding"), 0u);
  expect_error(curl("-H 'Accept-Encoding: identity;q=0'", server.url("/jobs/" + id + "/mesh?format=draco")), 406,
               "not_acceptable", "identity refused for draco");
  expect_error(curl("-H 'Accept-Encoding: *;q=0'", url), 406, "not_acceptable", "everything refused");
  EXPECT_EQ(curl("-H 'Accept-Encoding: identity;q=0, gzip'", url).headers.at("content-encoding"), "gzip");

  // POST /mesh negotiates too; JSON bodies of 1 KiB or more are compressed on the fly.
  const curl_reply posted = curl("--compressed -H 'Accept-Encoding: gzip' -F pqr=@" +
                                     molecule_path("fas2.pqr").string() + " -F density=1",
                                 server.url("/mesh"));
  EXPECT_EQ(posted.headers.at("content-encoding"), "gzip");
  EXPECT_TRUE(posted.body == identity.body);
  const curl_reply document = curl("--compressed -H 'Accept-Encoding: br'", server.url("/jobs/" + id));
  EXPECT_EQ(document.headers.at("content-encoding"), "br");
  EXPECT_EQ(nlohmann::json::parse(document.body).at("id"), id);
}

TEST_F(TracemeshdTest, TwentyConcurrentDistinctUploadsAllSucceed) {
  server_process server(work_.path(), {"--workers", "2", "--max-queue", "32"});
  std::string script;
  for (int i = 0; i < 20; ++i) {
    script += std::string(TRACEMESH_CURL) + " -s -o " + (work_.path() / ("distinct" + std::to_string(i))).string() +
              " -w '%{http_code}\\n' -F pqr=@" + molecule_path("gly.pqr").string() + " -F t0=" +
              std::to_string(0.8 + 0.01 * i) + " '" + server.url("/mesh") + "' & ";
  }
  const std::string codes = run("(" + script + "wait)");
  EXPECT_EQ(std::count(codes.begin(), codes.end(), '\n'), 20) << codes;
  EXPECT_EQ(codes.find_first_not_of("200\n"), std::string::npos) << codes;
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(read_file(work_.path() / ("distinct" + std::to_string(i))).rfind("OFF\n", 0), 0u) << i;
  }
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 20);
}

TEST_F(TracemeshdTest, TwentyConcurrentIdenticalUploadsRunTheMesherOnce) {
  server_process server(work_.path(), {"--workers", "2"});
  std::string script;
  for (int i = 0; i < 20; ++i) {
    script += std::string(TRACEMESH_CURL) + " -s -o " + (work_.path() / ("same" + std::to_string(i))).string() +
              " -w '%{http_code}\\n' -F pqr=@" + molecule_path("villin_1vii.pqr").string() + " '" +
              server.url("/mesh") + "' & ";
  }
  const std::string codes = run("(" + script + "wait)");
  EXPECT_EQ(std::count(codes.begin(), codes.end(), '\n'), 20) << codes;
  EXPECT_EQ(codes.find_first_not_of("200\n"), std::string::npos) << codes;
  const std::string reference = read_file(work_.path() / "same0");
  for (int i = 1; i < 20; ++i) EXPECT_EQ(read_file(work_.path() / ("same" + std::to_string(i))), reference) << i;
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 1);
}

TEST_F(TracemeshdTest, QueueOverflowGives429WithRetryAfter) {
  // No small-job lane: fas2 would run on it instead of waiting in the queue. The first job is held on the only
  // worker, so the queue holds exactly the second when the third arrives.
  const held_jobs held = hold_jobs();
  server_process server(work_.path(), {"--workers", "1", "--small-job-workers", "0", "--max-queue", "1"}, held);
  const fs::path fas2 = molecule_path("fas2.pqr");
  curl_reply running = upload(server, fas2, "-F density=2", "/jobs");
  EXPECT_TRUE(jobs_running(server)) << "the first job was never taken";
  curl_reply queued = upload(server, fas2, "-F density=2.5", "/jobs");
  curl_reply refused = upload(server, fas2, "-F density=3", "/jobs");
  EXPECT_EQ(running.status, 202) << running.body;
  EXPECT_EQ(queued.status, 202) << queued.body;
  expect_error(refused, 429, "queue_full", "third job");
  EXPECT_EQ(refused.headers["retry-after"], "5");
  EXPECT_EQ(curl("", server.url("/healthz")).status, 200);
  const std::string id = nlohmann::json::parse(running.body).at("id");
  curl_reply status = curl("", server.url("/jobs/" + id));
  const auto doc = nlohmann::json::parse(status.body);
  EXPECT_TRUE(doc.at("status") == "running" || doc.at("status") == "done") << doc;
  const auto queued_doc = nlohmann::json::parse(queued.body);
  curl_reply cancelled = curl("-X DELETE -H 'X-Job-Token: " + queued_doc.at("token").get<std::string>() + "'",
                              server.url("/jobs/" + queued_doc.at("id").get<std::string>()));
  EXPECT_EQ(cancelled.status, 200) << cancelled.body;
}

// Issue 11, item 5: PDB, mmCIF and xyzr uploads (field 'structure'); the same atoms are one job whatever the format.
TEST_F(TracemeshdTest, PdbMmcifAndXyzrOfOneMoleculeAreOneJob) {
  server_process server(work_.path(), {});
  const auto atoms = tracemesh::testing::atoms_of_pqr(read_file(molecule_path("fas2.pqr")));
  const fs::path pqr = write("fas2_bondi.pqr", tracemesh::testing::to_pqr(atoms, tracemesh::radii_set::bondi));
  const curl_reply first = upload(server, pqr);
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(first.headers.at("x-cache"), "miss");
  const std::string id = first.headers.at("x-job-id");
  const struct {
    const char* what;
    fs::path file;
  } others[] = {
      {"PDB", write("fas2.pdb", tracemesh::testing::to_pdb(atoms))},
      {"mmCIF", write("fas2.cif", tracemesh::testing::to_mmcif(atoms))},
      {"xyzr", write("fas2.xyzr", tracemesh::testing::to_xyzr(atoms, tracemesh::radii_set::bondi))},
  };
  for (const auto& other : others) {
    const curl_reply reply = curl("-F structure=@" + other.file.string(), server.url("/mesh"));
    ASSERT_EQ(reply.status, 200) << other.what << ": " << reply.body;
    EXPECT_EQ(reply.headers.at("x-job-id"), id) << other.what;
    EXPECT_EQ(reply.headers.at("x-cache"), "hit") << other.what;
    EXPECT_EQ(reply.body, first.body) << other.what;
  }
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 1);

  // Another radii set is another molecule, hence another job; options are form fields or query parameters.
  const curl_reply mantina =
      curl("-F structure=@" + others[0].file.string() + " -F radii=mantina", server.url("/jobs?hydrogens=keep"));
  EXPECT_EQ(mantina.status, 202) << mantina.body;
  EXPECT_EQ(mantina.body.find(id), std::string::npos) << mantina.body;

  expect_error(curl("-F structure=@" + pqr.string() + " -F pqr=@" + pqr.string(), server.url("/mesh")), 400,
               "invalid_input", "two files");
  expect_error(curl("-F structure=@" + pqr.string() + " -F radii=vdw", server.url("/mesh")), 400,
               "invalid_argument", "unknown radii set");
  expect_error(curl("-F structure=@" + pqr.string(), server.url("/mesh?waters=maybe")), 400, "invalid_argument",
               "bad waters option");
  const fs::path iron = write("iron.pdb", "HETATM    1 FE   HEM A   1       0.000   0.000   0.000  1.00 10.00          FE\n");
  const curl_reply no_radius = curl("-F structure=@" + iron.string(), server.url("/mesh"));
  expect_error(no_radius, 400, "invalid_input", "element without a Bondi radius");
  EXPECT_NE(no_radius.body.find("element Fe has no radius in the bondi set"), std::string::npos) << no_radius.body;
  const fs::path bad_pdb = write("bad.pdb", "HEADER\nATOM      1  CA  GLY A   1       1.000   abc     3.000  1.00 10.00           C\n");
  const curl_reply bad_line = curl("-F structure=@" + bad_pdb.string(), server.url("/mesh"));
  expect_error(bad_line, 400, "invalid_input", "bad PDB coordinate");
  EXPECT_NE(bad_line.body.find("line 2: y coordinate 'abc'"), std::string::npos) << bad_line.body;
}

// Issue 12, finding 8: a PQR line with a missing column was read with its columns shifted (200, a wrong mesh).
TEST_F(TracemeshdTest, APqrLineWithAMissingColumnIsRejectedNamingTheLine) {
  server_process server(work_.path(), {});
  const std::string fas2 = read_file(molecule_path("fas2.pqr"));
  const std::string fas2_chain = tracemesh::testing::with_chain_id(fas2, "A");
  ASSERT_EQ(upload(server, write("fas2_chain.pqr", fas2_chain)).status, 200) << "the 11-field layout is accepted";
  struct damaged {
    const char* what;
    std::string content;
  };
  const std::vector<damaged> cases = {
      {"no chain id, z missing", tracemesh::testing::without_field(fas2, 100, 7)},
      {"chain id, z missing", tracemesh::testing::without_field(fas2_chain, 100, 8)},
      {"chain id, charge missing", tracemesh::testing::without_field(fas2_chain, 100, 9)},
  };
  for (const damaged& c : cases) {
    for (const char* route : {"/mesh", "/jobs"}) {
      const curl_reply reply = upload(server, write("damaged.pqr", c.content), "", route);
      expect_error(reply, 400, "invalid_input", c.what);
      EXPECT_NE(reply.body.find("line 100: "), std::string::npos) << c.what << ": " << reply.body;
    }
  }
}

TEST_F(TracemeshdTest, BadInputsGetTheRight4xxAndTheServerKeepsServing) {
  server_process server(work_.path(), {"--max-atoms", "300", "--max-upload-bytes", "200000"});
  const fs::path gly = molecule_path("gly.pqr");
  struct bad_pqr {
    const char* what;
    std::string content;
    int status;
    const char* code;
  };
  const std::vector<bad_pqr> cases = {
      {"empty file", "", 422, "nothing_to_mesh"},
      {"only remarks", "REMARK 1\nTER\nEND\n", 422, "nothing_to_mesh"},
      {"NaN coordinate", "ATOM 1 N GLY 1 nan 0 0 0 1.5\n", 400, "invalid_input"},
      {"overflowing number", "ATOM 1 N GLY 1 1e400 0 0 0 1.5\n", 400, "invalid_input"},
      {"hex float", "ATOM 1 N GLY 1 0x1p3 0 0 0 1.5\n", 400, "invalid_input"},
      {"decimal comma", "ATOM 1 N GLY 1 1,5 0 0 0 1.5\n", 400, "invalid_input"},
      {"negative radius", "ATOM 1 N GLY 1 0 0 0 0 -1.5\n", 400, "invalid_input"},
      {"huge radius", "ATOM 1 N GLY 1 0 0 0 0 50\n", 400, "invalid_input"},
      {"huge coordinate", "ATOM 1 N GLY 1 1e9 0 0 0 1.5\n", 400, "invalid_input"},
      {"too few fields", "ATOM 1 N GLY 1 0 0\n", 400, "invalid_input"},
      {"binary garbage", std::string("\x7f" "ELF\x02\x01\x01\x00\x00\x00\x00", 12), 400, "invalid_input"},
      {"only zero radii", "ATOM 1 HG SER 1 0 0 0 0.4 0.0\n", 422, "nothing_to_mesh"},
      {"corrupt gzip", std::string("\x1f\x8b\x08\x00garbage", 11), 400, "invalid_input"},
  };
  for (const bad_pqr& c : cases) {
    const fs::path path = write("bad.pqr", c.content);
    curl_reply reply = upload(server, path);
    expect_error(reply, c.status, c.code, c.what);
  }
  curl_reply named_line = upload(server, write("line3.pqr", "REMARK x\nATOM 1 N GLY 1 0 0 0 0 1.5\n"
                                                                  "ATOM 2 N GLY 1 0 0 inf 0 1.5\n"));
  EXPECT_NE(named_line.body.find("line 3"), std::string::npos) << named_line.body;
  expect_error(upload(server, molecule_path("villin_1vii.pqr")), 413, "limit_exceeded", "596 atoms over 300");
  expect_error(upload(server, gly, "-F density=0"), 400, "invalid_argument", "density out of range");
  expect_error(upload(server, gly, "-F d=1"), 400, "invalid_argument", "positive decay");
  expect_error(upload(server, gly, "-F t0=nan"), 400, "invalid_argument", "NaN isovalue");
  expect_error(upload(server, gly, "-F format=stl"), 400, "invalid_argument", "unknown format");
  expect_error(curl("-F other=@" + gly.string(), server.url("/mesh")), 400, "invalid_input", "no pqr field");
  expect_error(curl("--data-binary @" + gly.string() + " -H 'Content-Type: text/plain'", server.url("/mesh")), 415,
               "unsupported_media_type", "not multipart");
  expect_error(curl("", server.url("/jobs/" + std::string(64, '0'))), 404, "not_found", "unknown job");
  expect_error(curl("", server.url("/jobs/..%2F..%2Fetc%2Fpasswd")), 400, "invalid_argument", "traversal");
  expect_error(curl("-X PUT", server.url("/mesh")), 405, "method_not_allowed", "PUT");

  // curl sends Expect: 100-continue for this 1.1 MB body: the 413 comes from Content-Length, without reading the
  // body. curl is told to wait for the server's answer longer than it may run at all, so it never sends the body on
  // its own: a server that waited for the body would get none, and curl would give up (status 0).
  expect_error(upload(server, molecule_path("achbp.pqr"), "--expect100-timeout 600 --max-time 60"), 413,
               "limit_exceeded", "upload over the byte limit");

  EXPECT_EQ(curl("", server.url("/healthz")).status, 200);
  curl_reply good = upload(server, gly);
  EXPECT_EQ(good.status, 200) << good.body;
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 1);
}

TEST_F(TracemeshdTest, KillDuringCacheWritesLeavesAUsableCache) {
  const fs::path villin = molecule_path("villin_1vii.pqr");
  std::string reference;
  {
    temp_dir clean_cache;
    server_process server(work_.path(), {"--cache-dir", clean_cache.path().string()});
    reference = upload(server, villin).body;
    ASSERT_EQ(reference.rfind("OFF\n", 0), 0u);
  }
  // Kill -9 at moments spread over the job (meshing, encoding, the three cache writes), restarting each time on
  // the same cache directory; whatever was left must never be served wrong.
  for (int delay_ms : {150, 300, 400, 450, 500, 550, 600, 700}) {
    server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
    std::thread client([&] { upload(server, villin); });
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    server.kill(SIGKILL);
    client.join();
  }
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  curl_reply after = upload(server, villin);
  ASSERT_EQ(after.status, 200);
  EXPECT_EQ(after.body, reference) << "X-Cache: " << after.headers["x-cache"];
  EXPECT_EQ(upload(server, villin).headers["x-cache"], "hit");
  EXPECT_EQ(metric(server, "tracemesh_cache_corrupt_entries_total"), 0);
}

TEST_F(TracemeshdTest, SigtermFinishesRunningWorkThenExitsZero) {
  // The job is held until the shutdown has begun, so it is running at SIGTERM however fast it meshes. Generous
  // grace: sanitizer builds are slow.
  const held_jobs held = hold_jobs();
  server_process server(work_.path(), {"--shutdown-grace", "120", "--cache-dir", cache_.path().string()}, held);
  curl_reply waiting;
  std::thread client([&] { waiting = upload(server, molecule_path("villin_1vii.pqr")); });
  EXPECT_TRUE(jobs_running(server)) << "the job was never taken";
  server.send(SIGTERM);
  EXPECT_TRUE(eventually([&] { return server.log().find("\"event\":\"shutdown_started\"") != std::string::npos; }))
      << server.log();
  open_gate(held);
  EXPECT_EQ(server.wait_exit(), 0);
  client.join();
  EXPECT_EQ(waiting.status, 200) << "the running job finishes within the grace period";
  EXPECT_EQ(waiting.headers["connection"], "close") << "in-flight responses close their connection";
  EXPECT_EQ(off_counts(waiting.body).first > 0, true);
  EXPECT_TRUE(temporary_files(cache_.path()).empty()) << temporary_files(cache_.path()).front();
  EXPECT_FALSE(fs::is_empty(cache_.path())) << "the finished job was cached before the exit";
  const std::string log = server.log();
  EXPECT_NE(log.find("\"event\":\"shutdown_done\""), std::string::npos) << log;
  EXPECT_EQ(log.find("ATOM"), std::string::npos) << "no PQR content in logs";
}

TEST_F(TracemeshdTest, SigtermCancelsWorkStillRunningAtTheGraceDeadline) {
  // The job is held (its gate never opens): it is still running at the grace deadline however fast it would mesh.
  server_process server(work_.path(), {"--shutdown-grace", "0.05", "--cache-dir", cache_.path().string()},
                        hold_jobs());
  curl_reply waiting;
  std::thread client([&] { waiting = upload(server, molecule_path("fas2.pqr"), "-F density=4"); });
  EXPECT_TRUE(jobs_running(server)) << "the job was never taken";
  EXPECT_EQ(server.kill(SIGTERM), 0);  // the deadline shows in the reply, not in a stopwatch a loaded machine can miss
  client.join();
  expect_error(waiting, 503, "shutdown", "job cancelled at the grace deadline");
  EXPECT_EQ(waiting.headers["retry-after"], "5");
  EXPECT_TRUE(temporary_files(cache_.path()).empty()) << temporary_files(cache_.path()).front();
}

/// The events of a complete GET /jobs/{id}/events response read by `curl -N`.
std::vector<tracemesh::testing::sse_event> expect_event_stream(const curl_reply& reply) {
  EXPECT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.headers.count("content-type") ? reply.headers.at("content-type") : "", "text/event-stream");
  EXPECT_EQ(reply.headers.count("cache-control") ? reply.headers.at("cache-control") : "", "no-store");
  return tracemesh::testing::parse_sse(reply.body);
}

TEST_F(TracemeshdTest, AnEventStreamFollowsARealJobToItsDoneEvent) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  // The trace path at density 2: several stages and a few hundred milliseconds of work, so there is progress to see.
  const curl_reply accepted = upload(server, molecule_path("fas2.pqr"), "-F method=trace -F density=2", "/jobs");
  ASSERT_EQ(accepted.status, 202) << accepted.body;
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  const curl_reply stream = curl("-N --max-time 120", server.url("/jobs/" + id + "/events"));
  const auto events = expect_event_stream(stream);
  ASSERT_GE(events.size(), 2u) << stream.body;
  double progress = 0;
  for (std::size_t i = 0; i + 1 < events.size(); ++i) {
    EXPECT_EQ(events[i].name, "progress") << i;
    const auto doc = nlohmann::json::parse(events[i].data);
    EXPECT_GE(doc.at("progress").get<double>(), progress) << "event " << i << " went backwards";
    progress = doc.at("progress");
    EXPECT_TRUE(doc.at("eta_s").is_null() || doc.at("eta_s").get<double>() >= 0) << doc;
  }
  EXPECT_EQ(events.back().name, "done");
  const auto final_doc = nlohmann::json::parse(events.back().data);
  const curl_reply polled = curl("", server.url("/jobs/" + id));
  EXPECT_EQ(final_doc, nlohmann::json::parse(polled.body)) << "the done event carries GET /jobs/{id}";
  expect_certified_job(server, final_doc);

  // A finished job: its connect and done events at once; an unknown job: 404 JSON.
  const auto again = expect_event_stream(curl("-N --max-time 20", server.url("/jobs/" + id + "/events")));
  ASSERT_EQ(again.size(), 2u);
  EXPECT_EQ(again[1].name, "done");
  // (The report has gained the OFF encoding fetched above: the events carry the document as GET has it now.)
  EXPECT_EQ(nlohmann::json::parse(again[1].data), nlohmann::json::parse(curl("", server.url("/jobs/" + id)).body));
  expect_error(curl("-N --max-time 20", server.url("/jobs/" + std::string(64, '0') + "/events")), 404,
               "not_found", "events of an unknown job");
}

TEST_F(TracemeshdTest, AnEventStreamOfAFailingJobEndsWithAnErrorEvent) {
  // Inputs the mesher would refuse are refused at upload (422), before any job exists; a job that fails is one
  // past its deadline: held (its gate never opens), it is still running at its deadline however fast it would mesh.
  server_process server(work_.path(), {"--job-timeout", "0.01", "--cache-dir", cache_.path().string()},
                        hold_jobs());
  const curl_reply accepted = upload(server, molecule_path("fas2.pqr"), "-F density=2", "/jobs");
  ASSERT_EQ(accepted.status, 202) << accepted.body;
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  const auto events = expect_event_stream(curl("-N --max-time 60", server.url("/jobs/" + id + "/events")));
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().name, "error");
  const auto final_doc = nlohmann::json::parse(events.back().data);
  EXPECT_EQ(final_doc.at("status"), "failed");
  EXPECT_EQ(final_doc.at("error").at("code"), "timeout");
  EXPECT_EQ(final_doc, nlohmann::json::parse(curl("", server.url("/jobs/" + id)).body));
}

TEST_F(TracemeshdTest, CavitiesDropIsItsOwnJobAndDeliversOnlyTheOuterSurface) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const fs::path shell = write("shell.xyzr", tracemesh::testing::shell_with_island_xyzr());
  const nlohmann::json kept = run_job(server, shell, "");
  const nlohmann::json dropped = run_job(server, shell, "-F cavities=drop");
  const nlohmann::json dropped_by_query = run_job(server, shell, "", "?cavities=drop");
  ASSERT_EQ(kept.value("status", ""), "done") << kept;
  ASSERT_EQ(dropped.value("status", ""), "done") << dropped;
  EXPECT_NE(kept.at("id"), dropped.at("id")) << "the parameter is part of the job id";
  EXPECT_EQ(dropped_by_query.at("id"), dropped.at("id")) << "form field and query parameter are one parameter";
  EXPECT_EQ(run_job(server, shell, "-F cavities=keep").at("id"), kept.at("id")) << "keep is the default";

  const nlohmann::json keep_report = expect_certified_job(server, kept);
  const nlohmann::json drop_report = expect_certified_job(server, dropped);
  EXPECT_EQ(keep_report.at("cavity_mode"), "keep");
  EXPECT_EQ(drop_report.at("cavity_mode"), "drop");
  ASSERT_EQ(keep_report.at("components").size(), 3u);
  EXPECT_EQ(keep_report.at("components")[0].at("enclosed"), false);
  EXPECT_EQ(keep_report.at("components")[1].at("enclosed"), true);
  EXPECT_EQ(keep_report.at("components")[2].at("enclosed"), true);
  ASSERT_EQ(drop_report.at("components").size(), 1u);
  EXPECT_EQ(drop_report.at("dropped_components"), 2);
  EXPECT_EQ(drop_report.at("components")[0].at("vertices"), keep_report.at("components")[0].at("vertices"));
  const double outer_volume = keep_report.at("components")[0].at("volume");
  EXPECT_NEAR(drop_report.at("volume").get<double>(), outer_volume, 1e-9 * outer_volume);
  expect_error(upload(server, shell, "-F cavities=some"), 400, "invalid_argument", "a bad cavities value");
}

TEST_F(TracemeshdTest, AJobPastItsDeadlineAnswers504AndIsNotCached) {
  // Held (its gate never opens): the job is still running at its deadline however fast it would mesh.
  server_process server(work_.path(), {"--job-timeout", "0.01", "--cache-dir", cache_.path().string()},
                        hold_jobs());
  curl_reply late = upload(server, molecule_path("fas2.pqr"));
  expect_error(late, 504, "timeout", "synchronous job past --job-timeout");
  EXPECT_TRUE(late.headers["retry-after"].empty());
  EXPECT_EQ(metric(server, "tracemesh_cache_entries"), 0) << "a failed job is not cached";
  EXPECT_EQ(curl("", server.url("/healthz")).status, 200);
}

/// The server's JSON log lines with the given event.
std::vector<nlohmann::json> log_events(const std::string& log, const std::string& event) {
  std::vector<nlohmann::json> out;
  std::istringstream lines(log);
  std::string line;
  while (std::getline(lines, line)) {
    const nlohmann::json doc = nlohmann::json::parse(line, nullptr, false);
    if (!doc.is_discarded() && doc.value("event", "") == event) out.push_back(doc);
  }
  return out;
}

TEST_F(TracemeshdTest, LogsHaveOneAccessLinePerRequestAndErrorLinesFor5xxCorruptionAndLostResults) {
  // Finding 12: a 503's logged duration was the server's uptime; no request id; cache corruption only in metrics;
  // 5xx not at error level.
  std::map<std::string, int> expected;  // request id → status
  // Request id → how long the client waited for it: the logged duration (from the request's first byte to the
  // response's last) cannot exceed it, however slow the machine.
  std::map<std::string, double> waited_ms;
  const auto timed = [](const std::function<curl_reply()>& request, double& ms) {
    const auto started = std::chrono::steady_clock::now();
    curl_reply reply = request();
    ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    return reply;
  };
  {
    server_process server(work_.path(), {"--cache-dir", cache_.path().string(), "--max-connections", "1",
                                         "--health-connection-reserve", "0"});
    double ms = 0;
    curl_reply health = timed([&] { return curl("-H 'X-Request-Id: it-health'", server.url("/healthz")); }, ms);
    EXPECT_EQ(health.headers["x-request-id"], "it-health");
    expected["it-health"] = 200;
    waited_ms["it-health"] = ms;
    const curl_reply mesh =
        timed([&] { return upload(server, molecule_path("gly.pqr"), "-H 'X-Request-Id: it-mesh'"); }, ms);
    EXPECT_EQ(mesh.status, 200);
    expected["it-mesh"] = 200;
    waited_ms["it-mesh"] = ms;
    curl_reply missing = timed([&] { return curl("", server.url("/nowhere")); }, ms);
    EXPECT_EQ(missing.headers["x-request-id"].size(), 16u) << "a generated id";
    expected[missing.headers["x-request-id"]] = 404;
    waited_ms[missing.headers["x-request-id"]] = ms;
    // Let the server be up a while (the bug logged its uptime as the 503's duration: now longer than the client
    // waits for the 503), then fill its only connection and get a 503.
    std::this_thread::sleep_for(1500ms);
    tracemesh::testing::raw_connection busy(server.port());
    ASSERT_TRUE(busy.send("GET /healthz HTTP/1.1\r\n"));
    // The server takes connections in the order they came, so `busy` holds the only one before the next arrives;
    // a request answered anyway is one more line to check.
    curl_reply refused;
    EXPECT_TRUE(tracemesh::testing::eventually([&] {
      refused = timed([&] { return curl("", server.url("/healthz")); }, ms);
      const std::string id = refused.headers["x-request-id"];
      if (!id.empty()) {
        expected[id] = refused.status;
        waited_ms[id] = ms;
      }
      return refused.status == 503;
    }));
    EXPECT_EQ(refused.status, 503);
    EXPECT_EQ(refused.headers["x-request-id"].size(), 16u) << "refused before reading: its own id";
    busy.close();
    EXPECT_EQ(server.kill(SIGTERM), 0);

    const std::string log = server.log();
    const std::vector<nlohmann::json> access = log_events(log, "access");
    for (const auto& [id, status] : expected) {
      int lines = 0;
      for (const auto& line : access) {
        if (line.at("request_id") != id) continue;
        ++lines;
        EXPECT_EQ(line.at("status"), status) << line;
        EXPECT_EQ(line.at("client"), "127.0.0.1") << line;
        EXPECT_GT(line.at("bytes").get<double>(), 0) << line;
        EXPECT_LE(line.at("ms").get<double>(), waited_ms.at(id) + 1.0)
            << "the duration runs from the request's first byte: " << line;
        EXPECT_EQ(line.at("level"), status >= 500 ? "error" : "info") << line;
      }
      EXPECT_EQ(lines, 1) << "one access line for request " << id << "\n" << log;
    }
    for (const auto& line : access) {
      if (line.at("request_id") == "it-mesh") {
        EXPECT_EQ(line.at("method"), "POST");
        EXPECT_EQ(line.at("route"), "/mesh");
      }
    }
  }
  {
    // Corrupt every cache entry (not the job store's files under jobs/); the restarted server finds them corrupt,
    // says so at error level, and encodes again from the stored mesh.
    for (const auto& entry : fs::recursive_directory_iterator(cache_.path())) {
      if (!entry.is_regular_file() || entry.path().parent_path().parent_path().filename() == "jobs") continue;
      std::fstream file(entry.path(), std::ios::in | std::ios::out | std::ios::binary);
      file.seekp(-1, std::ios::end);
      file.put('\x7f');
    }
    server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
    EXPECT_EQ(upload(server, molecule_path("gly.pqr")).status, 200);
    EXPECT_EQ(server.kill(SIGTERM), 0);
    const std::vector<nlohmann::json> corrupt = log_events(server.log(), "cache_corrupt");
    ASSERT_FALSE(corrupt.empty()) << server.log();
    EXPECT_EQ(corrupt.front().at("level"), "error");
    EXPECT_EQ(corrupt.front().at("reason"), "checksum mismatch");
  }
  {
    // A done job whose stored mesh the job store lost (its result file removed; nothing was encoded, so nothing is
    // cached): the loss is an error line and a 404. The cache alone losing an encoding is no loss any more (the
    // store's mesh is encoded again: ADoneJobServesEveryFormatAfterItsCacheEntriesAreGone).
    temp_dir lost_cache;
    server_process server(work_.path(), {"--cache-dir", lost_cache.path().string()});
    const nlohmann::json job = run_job(server, molecule_path("gly.pqr"), "");
    ASSERT_EQ(job.value("status", ""), "done") << job;
    const std::string id = job.at("id");
    ASSERT_TRUE(fs::remove(lost_cache.path() / "jobs" / id.substr(0, 2) / (id + ".result")));
    expect_error(curl("", server.url("/jobs/" + id + "/mesh?format=off")), 404, "not_found", "lost");
    // POST /mesh of the same molecule makes the result again (and says it was lost).
    EXPECT_EQ(upload(server, molecule_path("gly.pqr")).status, 200);
    EXPECT_EQ(curl("", server.url("/jobs/" + id + "/mesh?format=off")).status, 200);
    EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 2);
    EXPECT_EQ(server.kill(SIGTERM), 0);
    const std::vector<nlohmann::json> lost = log_events(server.log(), "job_result_lost");
    ASSERT_EQ(lost.size(), 2u) << server.log();
    EXPECT_EQ(lost.front().at("level"), "error");
    EXPECT_EQ(lost.front().at("job"), id);
  }
}

// ---- formats (issue 11 item 4; issue 12 findings 3 and 9) --------------------------------------------------------

/// Runs the Khronos glTF validator (tests/node/validate_gltf.mjs) on `files`; its output, and whether it passed.
std::pair<bool, std::string> validate_gltf(const std::vector<fs::path>& files) {
  std::string command = TRACEMESH_NODE;
  command.append(" ").append(TRACEMESH_SOURCE_DIR).append("/tests/node/validate_gltf.mjs");
  for (const fs::path& file : files) command.append(" ").append(file.string());
  command.append(" 2>&1; echo \"exit=$?\"");
  const std::string out = run(command);
  return {out.find("exit=0") != std::string::npos, out};
}

TEST_F(TracemeshdTest, EveryFormatIsServedAndDecodesToTheCertifiedMesh) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const nlohmann::json job = run_job(server, molecule_path("fas2.pqr"), "-F format=glb");
  ASSERT_EQ(job.value("status", ""), "done") << job;
  // Encodings are made on request: when the job is done its report lists none yet.
  EXPECT_EQ(job.at("report").at("encodings"), nlohmann::json::object()) << job.at("report");
  const std::string id = job.at("id");
  EXPECT_EQ(job.at("links").at("mesh"), "/jobs/" + id + "/mesh?format=glb");
  std::map<std::string, curl_reply> meshes;
  for (const tracemesh::proto::mesh_format_info& row : tracemesh::proto::mesh_formats()) {
    meshes[std::string(row.name)] = curl("", server.url("/jobs/" + id + "/mesh?format=" + std::string(row.name)));
  }
  // Each format requested once is now in the report (expect_certified_job fetches the OFF again: a cache hit).
  const nlohmann::json done = nlohmann::json::parse(curl("", server.url("/jobs/" + id)).body);
  const nlohmann::json report = expect_certified_job(server, done);
  ASSERT_FALSE(report.empty());
  EXPECT_EQ(report.at("encodings").size(), tracemesh::proto::mesh_formats().size()) << report.at("encodings");
  std::vector<fs::path> glbs;
  for (const tracemesh::proto::mesh_format_info& row : tracemesh::proto::mesh_formats()) {
    const std::string name(row.name);
    SCOPED_TRACE(name);
    curl_reply& mesh = meshes[name];
    ASSERT_EQ(mesh.status, 200) << mesh.body;
    EXPECT_EQ(mesh.headers["content-type"], row.content_type);
    EXPECT_EQ(mesh.headers["content-disposition"],
              "attachment; filename=\"" + id.substr(0, 12) + std::string(row.extension) + "\"");
    // The report states every encoding: its size, and for Draco and float32 the check of what a reader decodes.
    const nlohmann::json& encoding = report.at("encodings").at(name);
    EXPECT_EQ(encoding.at("bytes"), mesh.body.size());
    if (row.positions != tracemesh::proto::position_encoding::decimal) {
      EXPECT_EQ(encoding.at("decoded_check").at("passed"), true) << encoding;
    }
    if (row.positions == tracemesh::proto::position_encoding::draco_grid) {
      EXPECT_LE(encoding.at("position_quantization").at("step").get<double>(), 0.01) << encoding;
    }
    const auto decoded = tracemesh::testing::read_delivered(mesh.body, row.format);
    ASSERT_TRUE(decoded) << decoded.error().message();
    EXPECT_EQ(decoded->mesh.vertex_count(), report.at("vertices").get<std::size_t>());
    EXPECT_EQ(decoded->mesh.triangle_count(), report.at("triangles").get<std::size_t>());
    tracemesh::testing::expect_sound(decoded->mesh, name);
    if (!decoded->component.empty()) {
      const std::int32_t components = *std::max_element(decoded->component.begin(), decoded->component.end()) + 1;
      EXPECT_EQ(static_cast<std::size_t>(components), report.at("components").size());
    }
    if (row.extension == ".glb") glbs.push_back(write(name + ".glb", mesh.body));
  }
  const auto [valid, output] = validate_gltf(glbs);
  EXPECT_TRUE(valid) << output;
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 1) << "one run serves every format";
}

TEST_F(TracemeshdTest, FormatsAreAcceptedByTheCliAndTheServiceAlike) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const fs::path glb = work_.path() / "gly.glb";
  const std::string cli = binary_path("tracemesh").string() + " " + molecule_path("gly.pqr").string() + " -o ";
  ASSERT_EQ(std::system((cli + glb.string()).c_str()), 0);
  const curl_reply served = upload(server, molecule_path("gly.pqr"), "-F format=glb");
  ASSERT_EQ(served.status, 200);
  EXPECT_EQ(served.body, read_file(glb)) << "the CLI and the service write the same bytes";
  const fs::path ply = work_.path() / "gly.ply";
  ASSERT_EQ(std::system((cli + ply.string()).c_str()), 0);
  EXPECT_EQ(upload(server, molecule_path("gly.pqr"), "-F format=ply").body, read_file(ply));
  expect_error(upload(server, molecule_path("gly.pqr"), "-F format=obj"), 400, "invalid_argument", "unknown format");
}

// Finding 3: two atoms 40,000 Å apart are a fine molecule; Draco cannot carry its mesh within 0.01 Å in float32,
// which must cost the Draco formats only: OFF (the default), PLY and GLB-raw are served, Draco and GLB get 413
// with the reason, and the report says so.
TEST_F(TracemeshdTest, FarApartAtomsAreServedAsOffAndRefusedOnlyByDraco) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const fs::path far = write("far.pqr",
                             "ATOM      1  C   GLY A   1  -20000.000   0.000   0.000  0.0000 1.7000\n"
                             "ATOM      2  C   GLY A   2   20000.000   0.000   0.000  0.0000 1.7000\n");
  curl_reply off = upload(server, far);
  ASSERT_EQ(off.status, 200) << off.body;
  const auto decoded = tracemesh::testing::read_off(off.body);
  ASSERT_TRUE(decoded);
  tracemesh::testing::expect_sound(decoded->mesh, "far-apart OFF");
  const std::string id = off.headers["x-job-id"];
  for (const char* format : {"draco", "glb"}) {
    expect_error(curl("", server.url("/jobs/" + id + "/mesh?format=" + format)), 413, "limit_exceeded", format);
    expect_error(upload(server, far, std::string("-F format=") + format), 413, "limit_exceeded", format);
  }
  EXPECT_EQ(curl("", server.url("/jobs/" + id + "/mesh?format=ply")).status, 200);
  const nlohmann::json job = nlohmann::json::parse(curl("", server.url("/jobs/" + id)).body);
  EXPECT_EQ(job.at("report").at("encodings").at("draco").at("error").at("code"), "limit_exceeded") << job;
  EXPECT_EQ(job.at("report").at("encodings").at("off").at("bytes"), off.body.size()) << job;
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 1);
  // Each refusal was found once and then answered from the report, without encoding again.
  std::map<std::string, int> encoded;
  for (const nlohmann::json& line : log_events(server.log(), "mesh_encoded")) ++encoded[line.at("format")];
  EXPECT_EQ(encoded, (std::map<std::string, int>{{"draco", 1}, {"glb", 1}, {"off", 1}, {"ply", 1}}));
}

TEST_F(TracemeshdTest, ServedOpenApiDocumentPassesAValidator) {
  server_process server(work_.path(), {});
  const curl_reply served = curl("", server.url("/openapi.json"));
  ASSERT_EQ(served.status, 200);
  const fs::path document = write("openapi.json", served.body);
  std::string command = TRACEMESH_NODE;
  command.append(" ").append(TRACEMESH_SOURCE_DIR).append("/tests/node/check_openapi.mjs lint ");
  command.append(document.string()).append(" 2>&1; echo \"exit=$?\"");
  const std::string out = run(command);
  EXPECT_NE(out.find("exit=0"), std::string::npos) << out;
}

// ---- issue 12: accepted work is durable; owners and bearer tokens ------------------------------------------------

/// The id and owner token of a 202 reply.
std::pair<std::string, std::string> id_and_token(const curl_reply& accepted) {
  const auto doc = nlohmann::json::parse(accepted.body);
  return {doc.at("id"), doc.value("token", "")};
}

/// `tracemeshd ARGS` run to its end: its exit code and everything it printed.
std::pair<int, std::string> run_tracemeshd(const std::string& args) {
  const std::string out =
      run(binary_path("tracemeshd").string() + " --listen 127.0.0.1:0 " + args + " 2>&1; echo \"exit=$?\"");
  const auto at = out.rfind("exit=");
  return {std::atoi(out.c_str() + at + 5), out.substr(0, at)};
}

// Finding 1: a done job's mesh lived only in the evictable cache. Now the job store keeps the mesh for the
// retention period: with the cache's files removed (and nothing held in memory) every format is still served.
TEST_F(TracemeshdTest, ADoneJobServesEveryFormatAfterItsCacheEntriesAreGone) {
  server_process server(work_.path(), {"--cache-dir", cache_.path().string(), "--cache-memory-bytes", "0"});
  const nlohmann::json job = run_job(server, molecule_path("gly.pqr"), "-F format=draco");
  ASSERT_EQ(job.value("status", ""), "done") << job;
  const std::string id = job.at("id");
  const curl_reply draco_before = curl("", server.url("/jobs/" + id + "/mesh?format=draco"));
  ASSERT_EQ(draco_before.status, 200);
  std::size_t removed = 0;
  for (const auto& shard : fs::directory_iterator(cache_.path())) {
    if (shard.path().filename() == "jobs") continue;
    removed += fs::remove_all(shard.path());
  }
  EXPECT_GT(removed, 0u) << "the cache held the encoding";
  const curl_reply off = curl("", server.url("/jobs/" + id + "/mesh?format=off"));
  EXPECT_EQ(off.status, 200) << off.body;
  EXPECT_GT(off_counts(off.body).first, 0);
  const curl_reply draco = curl("", server.url("/jobs/" + id + "/mesh?format=draco"));
  EXPECT_EQ(draco.status, 200) << draco.body;
  EXPECT_EQ(draco.body, draco_before.body) << "re-encoded from the stored mesh: the same bytes";
  EXPECT_EQ(nlohmann::json::parse(curl("", server.url("/jobs/" + id)).body).at("status"), "done");
  EXPECT_EQ(metric(server, "tracemesh_mesher_runs_total"), 1) << "served from the stored mesh, not meshed again";
  EXPECT_TRUE(log_events(server.log(), "job_result_lost").empty()) << "the cache losing an encoding loses nothing";
}

// Finding 14: a 202-accepted job vanished with kill -9. Now the journal queues it again at start.
TEST_F(TracemeshdTest, JobsAcceptedBeforeAKill9FinishAfterTheRestart) {
  std::vector<std::string> ids;
  {
    // Every job is held: the kill finds the first running and none finished, however fast the machine.
    server_process server(work_.path(), {"--cache-dir", cache_.path().string(), "--workers", "1"}, hold_jobs());
    for (const char* molecule : {"adp.pqr", "fas2.pqr", "villin_1vii.pqr", "gly.pqr"}) {
      const curl_reply accepted = upload(server, molecule_path(molecule), "", "/jobs");
      ASSERT_EQ(accepted.status, 202) << molecule << ": " << accepted.body;
      ids.push_back(id_and_token(accepted).first);
    }
    EXPECT_TRUE(jobs_running(server)) << "no job was taken";
    server.kill(SIGKILL);  // the first is running, the others queued (or running on the small-job lane)
  }
  server_process restarted(work_.path(), {"--cache-dir", cache_.path().string(), "--workers", "2"});
  EXPECT_NE(restarted.log().find("\"event\":\"jobs_requeued\""), std::string::npos) << restarted.log();
  for (const std::string& id : ids) {
    const curl_reply first = curl("", restarted.url("/jobs/" + id));
    ASSERT_EQ(first.status, 200) << "a 202-accepted job is known after kill -9: " << first.body;
    // Bounds only a job that never ends.
    const auto deadline = std::chrono::steady_clock::now() + 10min;
    nlohmann::json doc = nlohmann::json::parse(first.body);
    while (doc.at("status") != "done" && doc.at("status") != "failed" && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(50ms);
      doc = nlohmann::json::parse(curl("", restarted.url("/jobs/" + id)).body);
    }
    expect_certified_job(restarted, doc);
  }
}

// Finding 11: after kill -9 during a write the OFF was served but the Draco and the record were 404. Now a job is
// done with its mesh and every format, or queued to run again, never in between.
TEST_F(TracemeshdTest, Kill9AtAnyMomentLeavesAJobWholeOrQueuedAgain) {
  const fs::path villin = molecule_path("villin_1vii.pqr");
  std::string reference_off, reference_draco;
  {
    temp_dir clean;
    server_process server(work_.path(), {"--cache-dir", clean.path().string()});
    const nlohmann::json job = run_job(server, villin, "");
    ASSERT_EQ(job.value("status", ""), "done");
    reference_off = curl("", server.url("/jobs/" + job.at("id").get<std::string>() + "/mesh?format=off")).body;
    reference_draco = curl("", server.url("/jobs/" + job.at("id").get<std::string>() + "/mesh?format=draco")).body;
  }
  std::string id;
  for (int delay_ms : {0, 100, 250, 350, 450, 550, 700}) {
    server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
    const curl_reply accepted = upload(server, villin, "", "/jobs");
    ASSERT_TRUE(accepted.status == 202 || accepted.status == 200) << accepted.body;
    id = id_and_token(accepted).first;
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    server.kill(SIGKILL);
    // Straight after the kill the job must be known: done (whole) or waiting to run again.
    server_process checked(work_.path(), {"--cache-dir", cache_.path().string(), "--workers", "1"});
    const curl_reply status = curl("", checked.url("/jobs/" + id));
    ASSERT_EQ(status.status, 200) << "after a kill at " << delay_ms << " ms: " << status.body;
    const std::string state = nlohmann::json::parse(status.body).at("status");
    EXPECT_TRUE(state == "done" || state == "queued" || state == "running") << state;
    if (state == "done") {
      EXPECT_EQ(curl("", checked.url("/jobs/" + id + "/mesh?format=off")).body, reference_off) << delay_ms;
      EXPECT_EQ(curl("", checked.url("/jobs/" + id + "/mesh?format=draco")).body, reference_draco) << delay_ms;
    }
    checked.kill(SIGKILL);
    if (delay_ms < 700) fs::remove_all(cache_.path() / "jobs");  // the next round starts from nothing again
  }
  server_process server(work_.path(), {"--cache-dir", cache_.path().string()});
  const nlohmann::json final_state = run_job(server, villin, "");
  ASSERT_EQ(final_state.value("status", ""), "done") << final_state;
  EXPECT_EQ(curl("", server.url("/jobs/" + id + "/mesh?format=off")).body, reference_off);
  EXPECT_EQ(curl("", server.url("/jobs/" + id + "/mesh?format=draco")).body, reference_draco);
  EXPECT_EQ(metric(server, "tracemesh_cache_corrupt_entries_total"), 0);
}

// Finding 1: a read-only or unusable --cache-dir silently disabled caching. Now it stops the start with one line
// and exit 1; running without a disk store takes an explicit flag, and /readyz and the logs say so.
TEST_F(TracemeshdTest, AnUnusableCacheOrJobDirectoryStopsTheStartWithOneLine) {
  const fs::path file = write("plain-file", "not a directory");
  fs::path read_only = work_.path() / "read-only";
  if (::geteuid() == 0) {
    read_only = "/sys/kernel";  // root writes through permission bits; sysfs refuses new files even to root
  } else {
    fs::create_directory(read_only);
    fs::permissions(read_only, fs::perms::owner_read | fs::perms::owner_exec);
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--cache-dir " + file.string(), "not a directory"},
      {"--cache-dir " + (file / "below").string(), "cannot be created"},
      {"--cache-dir " + read_only.string(), "not writable"},
      {"--cache-dir " + (work_.path() / "ok").string() + " --job-dir " + file.string(), "not a directory"},
  };
  for (const auto& [args, reason] : cases) {
    const auto [code, output] = run_tracemeshd(args);
    EXPECT_EQ(code, 1) << args << ": " << output;
    EXPECT_EQ(std::count(output.begin(), output.end(), '\n'), 1) << args << ": " << output;
    EXPECT_NE(output.find(reason), std::string::npos) << args << ": " << output;
  }
  const auto [code, output] = run_tracemeshd("");
  EXPECT_EQ(code, 2) << output;
  EXPECT_NE(output.find("--no-disk-store"), std::string::npos) << output;

  server_process memory_only(work_.path(), {"--no-disk-store"});
  const curl_reply ready = curl("", memory_only.url("/readyz"));
  EXPECT_EQ(ready.status, 200);
  EXPECT_EQ(nlohmann::json::parse(ready.body).at("durable"), false) << ready.body;
  EXPECT_NE(memory_only.log().find("\"event\":\"no_disk_store\""), std::string::npos) << memory_only.log();
  server_process durable(work_.path(), {"--cache-dir", cache_.path().string()});
  EXPECT_EQ(nlohmann::json::parse(curl("", durable.url("/readyz")).body).at("durable"), true);
}

// Finding 2: any client could DELETE any job, and a second submitter of the same molecule lost its job. Now each
// submission gets an owner token; a shared job is cancelled only when every owner withdrew.
TEST_F(TracemeshdTest, ASharedJobIsCancelledOnlyWhenEveryOwnerWithdrew) {
  // No small-job lane: the shared fas2 job must stay queued behind the blocker, which is held on the only worker
  // (its gate never opens) however fast it would mesh.
  server_process server(work_.path(), {"--no-disk-store", "--workers", "1", "--small-job-workers", "0"},
                        hold_jobs());
  const curl_reply blocker = upload(server, molecule_path("villin_1vii.pqr"), "", "/jobs");
  ASSERT_EQ(blocker.status, 202) << blocker.body;
  ASSERT_TRUE(jobs_running(server)) << "the blocker was never taken";
  const curl_reply first = upload(server, molecule_path("fas2.pqr"), "", "/jobs");
  const curl_reply second = upload(server, molecule_path("fas2.pqr"), "", "/jobs");
  ASSERT_EQ(first.status, 202) << first.body;
  ASSERT_EQ(second.status, 202) << second.body;
  const auto [id, first_token] = id_and_token(first);
  const auto [same_id, second_token] = id_and_token(second);
  ASSERT_EQ(id, same_id) << "one job for both";
  EXPECT_NE(first_token, second_token) << "one token per submission";
  EXPECT_EQ(first.headers.at("x-job-token"), first_token);
  const std::string url = server.url("/jobs/" + id);
  expect_error(curl("-X DELETE", url), 401, "unauthorized", "no token");
  expect_error(curl("-X DELETE -H 'X-Job-Token: " + id_and_token(blocker).second + "'", url), 403, "forbidden",
               "another job's token");
  const curl_reply withdrawn = curl("-X DELETE -H 'X-Job-Token: " + first_token + "'", url);
  EXPECT_EQ(withdrawn.status, 200) << withdrawn.body;
  EXPECT_EQ(nlohmann::json::parse(withdrawn.body).at("status"), "queued") << "the second owner still holds it";
  expect_error(curl("-X DELETE -H 'X-Job-Token: " + first_token + "'", url), 403, "forbidden", "withdrawn twice");
  const curl_reply cancelled = curl("-X DELETE -H 'X-Job-Token: " + second_token + "'", url);
  EXPECT_EQ(cancelled.status, 200) << cancelled.body;
  EXPECT_EQ(nlohmann::json::parse(cancelled.body).at("status"), "cancelled") << "the last owner withdrew";
  EXPECT_EQ(curl("-X DELETE -H 'X-Job-Token: " + id_and_token(blocker).second + "'",
                 server.url("/jobs/" + id_and_token(blocker).first)).status, 200);
}

// Finding 2: there was no way to require a token. --auth-token-file makes every route but the exempt ones need
// "Authorization: Bearer".
TEST_F(TracemeshdTest, ABearerTokenFileGuardsEveryRouteButTheExemptOnes) {
  const fs::path tokens = write("tokens", "# lab tokens\nalpha-0123456789abcdef\n\n  beta-0123456789abcdef  \n");
  server_process server(work_.path(), {"--no-disk-store", "--auth-token-file", tokens.string()});
  const fs::path gly = molecule_path("gly.pqr");
  expect_error(upload(server, gly), 401, "unauthorized", "no token");
  expect_error(curl("-H 'Authorization: Bearer alpha-0123456789abcdeX'", server.url("/openapi.json")), 401,
               "unauthorized", "a wrong token");
  EXPECT_EQ(curl("", server.url("/openapi.json")).headers["www-authenticate"], "Bearer realm=\"tracemeshd\"");
  EXPECT_EQ(curl("-H 'Authorization: Bearer alpha-0123456789abcdef'", server.url("/openapi.json")).status, 200);
  EXPECT_EQ(curl("-F pqr=@" + gly.string() + " -H 'Authorization: bearer beta-0123456789abcdef'",
                 server.url("/mesh")).status, 200);
  for (const char* open_route : {"/healthz", "/readyz", "/metrics"}) {
    EXPECT_EQ(curl("", server.url(open_route)).status, 200) << open_route;
  }
  server_process strict(work_.path(), {"--no-disk-store", "--auth-token-file", tokens.string(), "--auth-exempt",
                                       "/healthz"});
  EXPECT_EQ(curl("", strict.url("/healthz")).status, 200);
  expect_error(curl("", strict.url("/metrics")), 401, "unauthorized", "metrics not exempt");
  const auto [code, output] = run_tracemeshd("--no-disk-store --auth-token-file " + write("short", "abc\n").string());
  EXPECT_EQ(code, 1) << output;
  EXPECT_NE(output.find("shorter than 16"), std::string::npos) << output;
}

// Issue 12, finding 10: a small job waited behind big ones. With one general worker busy on 2buk_12asu
// (34,284 atoms, over --small-job-max-atoms), fas2 (906 atoms) is meshed on the small-job lane meanwhile. The big
// job is held (its gate never opens; jobs over 20,000 atoms only) so it is still running, however fast the machine.
TEST_F(TracemeshdTest, ASmallJobIsMeshedWhileABigOneHoldsTheOnlyWorker) {
  server_process server(work_.path(), {"--workers", "1", "--small-job-workers", "1", "--small-job-max-atoms", "20000"},
                        hold_jobs(20001));
  const curl_reply big = upload(server, molecule_path("2buk_12asu.pqr"), "", "/jobs");
  ASSERT_EQ(big.status, 202) << big.body;
  const std::string big_url = server.url("/jobs/" + nlohmann::json::parse(big.body).at("id").get<std::string>());
  ASSERT_TRUE(jobs_running(server)) << "the big job was never taken";
  const curl_reply small = upload(server, molecule_path("fas2.pqr"));
  EXPECT_EQ(small.status, 200) << small.body;
  EXPECT_EQ(nlohmann::json::parse(curl("", big_url).body).at("status"), "running")
      << "fas2 was answered while the big job still ran";
  curl("-X DELETE -H 'X-Job-Token: " + nlohmann::json::parse(big.body).at("token").get<std::string>() + "'", big_url);
}

// Finding 7: one atom of radius ≤ 0.006 Å gave 500 internal_error (its certificate failed in the mesher). Now an
// atom too small for the density is the user's error, 422 unresolvable_input naming it, synchronously and as a job,
// alone or beside a real molecule, and the server keeps serving.
TEST_F(TracemeshdTest, ATinyAtomGets422NamingItNever500) {
  server_process server(work_.path(), {});
  const std::string tiny_atom = "ATOM      1  C   GLY     1       0.000   0.000   0.000  0.0000 0.0060\n";
  const fs::path lone = write("tiny.pqr", tiny_atom);
  std::string gly_and_tiny = read_file(molecule_path("gly.pqr"));
  if (gly_and_tiny.back() != '\n') gly_and_tiny += '\n';  // gly.pqr ends without a line break
  gly_and_tiny += "ATOM      9  C   GLY   562      20.000  20.000  20.000  0.0000 0.0010\n";
  const fs::path beside = write("gly-and-tiny.pqr", gly_and_tiny);
  for (const auto& [pqr, route] : {std::pair{lone, "/mesh"}, std::pair{lone, "/jobs"}, std::pair{beside, "/mesh"},
                                   std::pair{beside, "/jobs"}}) {
    for (const char* density : {"0.2", "1", "20"}) {
      const curl_reply reply = upload(server, pqr, std::string("-F density=") + density, route);
      expect_error(reply, 422, "unresolvable_input", pqr.filename().string() + " " + route + " density " + density);
      EXPECT_NE(reply.body.find("atom"), std::string::npos) << reply.body;
    }
  }
  EXPECT_EQ(upload(server, molecule_path("gly.pqr"), "").status, 200) << "the server keeps serving";
  EXPECT_FALSE(log_events(server.log(), "access").empty());
  for (const nlohmann::json& access : log_events(server.log(), "access")) {
    EXPECT_LT(access.value("status", 0), 500) << access;
  }
}

// ---- Chaos: kill -9 at random moments while jobs run and uploads stream (issue 12) ---------------------------
// TRACEMESH_CHAOS_ROUNDS (default 10; `make bench-chaos` runs 100) and TRACEMESH_CHAOS_SEED (default: random;
// the seed is printed, so a failing run is replayed exactly).

unsigned long chaos_setting(const char* name, unsigned long fallback) {
  const char* value = std::getenv(name);
  return value && *value ? std::strtoul(value, nullptr, 10) : fallback;
}

/// One round's traffic: job submissions (POST /jobs, one after the other) and a slow upload streaming beside them,
/// until the server dies. Every id answered 202 (or 200) lands in `accepted`.
class chaos_traffic {
 public:
  chaos_traffic(unsigned short port, std::mt19937& random, std::vector<std::string>& accepted, std::mutex& lock)
      : port_(port), accepted_(accepted), lock_(lock) {
    for (int i = 0; i < 4; ++i) submissions_.push_back(random_submission(random));
    slow_upload_ = tracemesh::testing::upload_request("/jobs", pqr_text("adp.pqr"),
                                                      {{"density", std::to_string(1 + random() % 2)}});
    submitter_ = std::thread([this] { submit_all(); });
    streamer_ = std::thread([this] { stream_slowly(); });
  }
  ~chaos_traffic() {
    submitter_.join();
    streamer_.join();
  }

 private:
  static std::string pqr_text(const std::string& molecule) {
    std::ifstream in(molecule_path(molecule), std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  /// A small molecule at a random density and t0, so that most submissions are new jobs.
  static std::string random_submission(std::mt19937& random) {
    static const std::array<const char*, 4> molecules = {"gly.pqr", "adp.pqr", "fas2.pqr", "villin_1vii.pqr"};
    static const std::array<const char*, 3> t0s = {"0.5", "1", "1.5"};
    return tracemesh::testing::upload_request(
        "/jobs", pqr_text(molecules[random() % molecules.size()]),
        {{"density", std::to_string(1 + random() % 2)}, {"t0", t0s[random() % t0s.size()]}});
  }

  void record(const tracemesh::testing::http_reply& reply) {
    if (reply.status != 202 && reply.status != 200) return;
    const auto doc = nlohmann::json::parse(reply.body, nullptr, false);
    if (doc.is_discarded() || !doc.contains("id")) return;
    std::lock_guard guard(lock_);
    accepted_.push_back(doc.at("id"));
  }

  void submit_all() {
    for (const std::string& request : submissions_) {
      const tracemesh::testing::http_reply reply = tracemesh::testing::round_trip(port_, request);
      if (reply.status == 0) return;  // the server is gone
      record(reply);
    }
  }

  /// The upload in 256-byte pieces every 10 ms: the kill usually finds it half sent.
  void stream_slowly() {
    tracemesh::testing::raw_connection connection(port_, 5s);
    if (!connection.connected() || !connection.send_in_chunks(slow_upload_, 256, 10ms)) return;
    record(connection.read_reply());
  }

  unsigned short port_;
  std::vector<std::string>& accepted_;
  std::mutex& lock_;
  std::vector<std::string> submissions_;
  std::string slow_upload_;
  std::thread submitter_;
  std::thread streamer_;
};

/// Every entry of the job store under `jobs_dir` whole: the store opens, nothing is lost, each of `ids` is done
/// and its stored mesh is closed, manifold and without degenerate triangles.
void expect_job_store_whole(const fs::path& jobs_dir, const std::set<std::string>& ids) {
  tracemesh::server::job_store_options options;
  options.dir = jobs_dir;
  tracemesh::server::job_store store(options);
  ASSERT_TRUE(store.open().ok());
  EXPECT_TRUE(store.take_lost().empty()) << "a job store entry was found damaged";
  EXPECT_TRUE(store.take_unfinished().empty()) << "every accepted job finished";
  for (const std::string& id : ids) {
    const auto record = store.find(id);
    ASSERT_TRUE(record.has_value()) << id;
    EXPECT_EQ(record->state, tracemesh::server::job_state::done) << id;
    const auto mesh = store.mesh(id);
    ASSERT_NE(mesh, nullptr) << "the stored mesh of " << id << " is unreadable";
    EXPECT_TRUE(tracemesh::analyze_mesh(*mesh).topologically_certified()) << id;
  }
}

/// Every result-cache entry file under `cache_dir` (shards of two hex digits) reads back whole: checksum and header.
void expect_cache_entries_whole(const fs::path& cache_dir) {
  tracemesh::server::result_cache cache(cache_dir, tracemesh::server::cache_limits{});
  std::vector<std::string> corrupt;
  cache.set_corruption_listener([&](const std::string& key, const char* reason) { corrupt.push_back(key + ": " + reason); });
  ASSERT_TRUE(cache.open().ok());
  std::size_t entries = 0;
  for (const auto& shard : fs::directory_iterator(cache_dir)) {
    if (!shard.is_directory() || shard.path().filename().string().size() != 2) continue;
    for (const auto& file : fs::directory_iterator(shard.path())) {
      const std::string key = file.path().filename().string();
      if (!tracemesh::server::is_valid_cache_key(key)) continue;
      ++entries;
      EXPECT_NE(cache.get(key), nullptr) << "cache entry " << key << " does not read back";
    }
  }
  EXPECT_TRUE(corrupt.empty()) << corrupt.front();
  std::cout << "chaos: " << entries << " cache entries checked\n";
}

TEST_F(TracemeshdTest, ChaosKill9WhileJobsRunAndUploadsStreamLosesNoAcceptedJob) {
  const unsigned long rounds = chaos_setting("TRACEMESH_CHAOS_ROUNDS", 10);
  const unsigned long seed = chaos_setting("TRACEMESH_CHAOS_SEED", std::random_device{}());
  std::cout << "chaos: " << rounds << " rounds, seed " << seed << " (TRACEMESH_CHAOS_SEED=" << seed
            << " replays it)\n";
  std::mt19937 random(static_cast<std::mt19937::result_type>(seed));
  const std::vector<std::string> args = {"--cache-dir", cache_.path().string(), "--workers", "2"};
  std::vector<std::string> accepted;
  std::mutex lock;
  auto server = std::make_unique<server_process>(work_.path(), args);
  for (unsigned long round = 1; round <= rounds; ++round) {
    const int kill_after_ms = static_cast<int>(random() % 800);
    {
      chaos_traffic traffic(server->port(), random, accepted, lock);
      if (round == 1) {  // so that the test always has a job to check, however slowly this machine accepts them
        EXPECT_TRUE(tracemesh::testing::eventually([&] {
          std::lock_guard guard(lock);
          return !accepted.empty();
        }));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(kill_after_ms));
      server->kill(SIGKILL);
    }  // the traffic threads see the connection die and stop
    server = std::make_unique<server_process>(work_.path(), args);
    const std::set<std::string> known(accepted.begin(), accepted.end());
    std::cout << "chaos round " << round << ": kill -9 after " << kill_after_ms << " ms, " << known.size()
              << " jobs accepted so far\n";
    // Straight after the restart every accepted job is known: done, or queued (running) again.
    for (const std::string& id : known) {
      const curl_reply reply = curl("", server->url("/jobs/" + id));
      ASSERT_EQ(reply.status, 200) << "round " << round << " (seed " << seed << "): job " << id << ": " << reply.body;
      const std::string state = nlohmann::json::parse(reply.body).at("status");
      EXPECT_TRUE(state == "done" || state == "queued" || state == "running")
          << "round " << round << " (seed " << seed << "): job " << id << " is " << state << ": " << reply.body;
    }
  }
  const std::set<std::string> known(accepted.begin(), accepted.end());
  ASSERT_FALSE(known.empty()) << "no job was accepted in " << rounds << " rounds: the test checked nothing";
  for (const std::string& id : known) {
    const auto deadline = std::chrono::steady_clock::now() + 300s;
    nlohmann::json doc = nlohmann::json::parse(curl("", server->url("/jobs/" + id)).body);
    while (doc.at("status") != "done" && doc.at("status") != "failed" && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(50ms);
      const curl_reply reply = curl("", server->url("/jobs/" + id));
      ASSERT_EQ(reply.status, 200) << "job " << id << " (seed " << seed << "): " << reply.body;
      doc = nlohmann::json::parse(reply.body);
    }
    expect_certified_job(*server, doc);
  }
  EXPECT_EQ(metric(*server, "tracemesh_cache_corrupt_entries_total"), 0) << "seed " << seed;
  EXPECT_TRUE(log_events(server->log(), "job_result_lost").empty()) << server->log();
  EXPECT_EQ(server->kill(SIGTERM), 0);
  expect_job_store_whole(cache_.path() / "jobs", known);
  expect_cache_entries_whole(cache_.path());
}

}  // namespace
