#pragma once
// The fixture shared by service_test.cpp (the API through a running service) and http_server_test.cpp (the HTTP
// transport): a real service on a loopback port with a fake mesher behind a gate, talked to over raw sockets.
// Every error reply is checked against proto/openapi.json (its code is one the document lists), and at the end of
// each test every status the service answered on a documented path must be documented for that path.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "proto/openapi.hpp"
#include "server/observability/logging.hpp"
#include "server/service.hpp"
#include "support/eventually.hpp"
#include "support/test_http_client.hpp"
#include "support/test_paths.hpp"

namespace tracemesh::server::test {

using namespace std::chrono_literals;
using tracemesh::testing::get_request;
using tracemesh::testing::http_reply;
using tracemesh::testing::raw_connection;
using tracemesh::testing::round_trip;
using tracemesh::testing::upload_request;

/// Stands in for mesh_molecule: a tetrahedron, after a gate the test may hold closed (polling the token). Keeps the
/// parameters of its last run; for the trace method it reports the tracing stage and fills trace_stats with
/// recognisable numbers (lines 11, polygons 4, field_evaluations 40 for 4 raw vertices...).
class fake_mesher {
 public:
  mesher_function function() {
    return [this](const molecule& mol, const mesh_params& params, const mesh_limits&,
                  progress_token& token) -> result<mesh_output> {
      runs_.fetch_add(1);
      std::unique_lock lock(mutex_);
      last_params_ = params;
      const mesh_stage stage = params.method == mesh_method::trace ? mesh_stage::tracing : mesh_stage::sampling;
      while (!open_ && mol.atoms.size() >= gate_min_atoms_) {
        if (!token.report(stage, 0.25)) return status(errc::cancelled, "cancelled");
        changed_.wait_for(lock, 2ms);
      }
      mesh_output out;
      out.method = params.method;
      out.refine = params.refine;
      if (params.method == mesh_method::trace) {
        out.trace.line_spacing = 1.0 / std::sqrt(params.density);
        out.trace.step = params.trace.step_fraction * out.trace.line_spacing;
        out.trace.lines = 11;
        out.trace.polynomial_roots = 6;
        out.trace.arcs = 6;
        out.trace.polygons = 4;
        out.trace.fallback_loops = 0;
        out.trace.field_evaluations = 40;
        out.trace.raw_vertices = 4;
        out.trace.raw_triangles = 4;
      }
      const double r = mol.atoms.empty() ? 1.0 : mol.atoms.front().radius;
      out.mesh.positions = {{r, r, r}, {r, -r, -r}, {-r, r, -r}, {-r, -r, r}};
      out.mesh.triangles = {{{0, 1, 2}}, {{0, 3, 1}}, {{0, 2, 3}}, {{1, 3, 2}}};
      out.report.vertices = 4;
      out.report.triangles = 4;
      out.atoms_meshed = mol.atoms.size();
      out.certified = true;
      return out;
    };
  }
  void set_open(bool open) {
    std::lock_guard lock(mutex_);
    open_ = open;
    changed_.notify_all();
  }
  /// Only molecules of at least `atoms` atoms wait at the closed gate; smaller ones pass (default 0: all wait).
  void set_gate_min_atoms(std::size_t atoms) {
    std::lock_guard lock(mutex_);
    gate_min_atoms_ = atoms;
  }
  int runs() const { return runs_.load(); }
  /// The parameters of the last run (mesh_params{} before any).
  mesh_params last_params() {
    std::lock_guard lock(mutex_);
    return last_params_;
  }

 private:
  std::mutex mutex_;
  mesh_params last_params_;
  std::condition_variable changed_;
  bool open_ = true;
  std::size_t gate_min_atoms_ = 0;
  std::atomic<int> runs_{0};
};

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

inline std::string atom_line(int serial, double x, double radius = 1.5) {
  std::ostringstream line;
  line << "ATOM " << serial << " C ALA 1 " << x << " 0.0 0.0 0.0 " << radius << "\n";
  return line.str();
}

using tracemesh::testing::eventually;

inline const nlohmann::json& openapi() {
  static const nlohmann::json document = nlohmann::json::parse(proto::openapi_document());
  return document;
}

/// The error codes proto/openapi.json lists (the enum of Error.error.code).
inline std::set<std::string> documented_error_codes() {
  std::set<std::string> codes;
  const auto& code = openapi().at("components").at("schemas").at("Error").at("properties").at("error").at(
      "properties").at("code");
  for (const auto& value : code.at("enum")) codes.insert(value.get<std::string>());
  return codes;
}

/// Every status documented for any operation of `path` ("/jobs/{id}").
inline std::set<unsigned> documented_statuses(const std::string& path) {
  std::set<unsigned> statuses;
  for (const auto& [method, operation] : openapi().at("paths").at(path).items()) {
    if (!operation.is_object() || !operation.contains("responses")) continue;
    for (const auto& [code, response] : operation.at("responses").items()) {
      statuses.insert(static_cast<unsigned>(std::stoul(code)));
    }
  }
  return statuses;
}

class service_fixture : public ::testing::Test {
 protected:
  void start(const std::function<void(server_config&)>& adjust = {}) {
    config_.listen_port = 0;
    config_.workers = 1;
    config_.limits.max_upload_bytes = 256 * 1024;
    config_.limits.max_queue = 4;
    // Deadlines no test reaches unless it sets them itself to exercise them: a loaded machine that stalls a test
    // between two requests must not have its connections cut under it.
    config_.limits.header_timeout = 60s;
    config_.limits.request_timeout = 60s;
    config_.limits.write_timeout = 60s;
    config_.limits.shutdown_grace = 200ms;
    config_.limits.job_timeout = std::chrono::minutes(10);
    if (adjust) adjust(config_);
    service_ = std::make_unique<service>(config_, make_null_logger(), mesher_.function());
    const status started = service_->start();
    ASSERT_TRUE(started.ok()) << started.message();
    port_ = service_->port();
  }
  void TearDown() override {
    mesher_.set_open(true);
    if (!service_) return;
    service_->shutdown();
    expect_answered_statuses_documented();
  }

  http_reply post(const std::string& target, const std::string& pqr,
                  const std::vector<std::pair<std::string, std::string>>& fields = {}) {
    return round_trip(port_, upload_request(target, pqr, fields));
  }
  http_reply get(const std::string& target, const std::string& headers = {}) {
    return round_trip(port_, get_request(target, headers));
  }
  http_reply request(const std::string& method, const std::string& target, const std::string& headers = {}) {
    return round_trip(port_, method + " " + target + " HTTP/1.1\r\nHost: test\r\n" + headers + "\r\n",
                      method == "HEAD");
  }
  /// DELETE /jobs/{id} with the owner token of its submission (`accepted`: the 202 reply of POST /jobs).
  http_reply withdraw(const http_reply& accepted) {
    const auto doc = nlohmann::json::parse(accepted.body);
    return request("DELETE", "/jobs/" + doc.at("id").get<std::string>(),
                   "X-Job-Token: " + doc.at("token").get<std::string>() + "\r\n");
  }
  /// Polls GET /jobs/{id} until the job is final: its document; {"http": status} when the job is unknown,
  /// {"status": "never final"} when it stayed unfinished past eventually()'s deadline.
  nlohmann::json wait_job(const std::string& id) {
    nlohmann::json doc;
    const bool final = eventually([&] {
      const http_reply r = get("/jobs/" + id);
      if (r.status != 200) {
        doc = nlohmann::json{{"http", r.status}};
        return true;
      }
      doc = nlohmann::json::parse(r.body);
      const std::string state = doc.at("status");
      return state == "done" || state == "failed" || state == "cancelled";
    });
    return final ? doc : nlohmann::json{{"status", "never final"}};
  }
  /// Waits until no job is queued or running.
  bool jobs_settled() {
    return eventually([&] { return service_->jobs().queue_depth() == 0 && service_->jobs().running_jobs() == 0; });
  }
  void expect_error(const http_reply& r, int status, const std::string& code) {
    EXPECT_EQ(r.status, status) << r.body;
    if (r.status == 0) return;
    const auto doc = nlohmann::json::parse(r.body, nullptr, false);
    ASSERT_FALSE(doc.is_discarded()) << r.body;
    EXPECT_EQ(doc["error"]["code"], code) << r.body;
    EXPECT_EQ(documented_error_codes().count(code), 1u) << "error code missing from openapi.json: " << code;
    EXPECT_FALSE(doc["error"]["message"].get<std::string>().empty());
  }

  /// Every (route, status) counted by the metrics on a path of openapi.json is documented for that path.
  /// 204 (CORS preflight answers to OPTIONS) is transport, not API, and is not documented per path.
  void expect_answered_statuses_documented() {
    std::istringstream lines(service_->stats().render({}));
    const std::string prefix = "tracemesh_http_requests_total{route=\"";
    std::string line;
    while (std::getline(lines, line)) {
      if (line.rfind(prefix, 0) != 0) continue;
      const std::size_t route_end = line.find('"', prefix.size());
      const std::string route = line.substr(prefix.size(), route_end - prefix.size());
      const std::size_t status_at = line.find("status=\"", route_end) + 8;
      const unsigned status = static_cast<unsigned>(std::stoul(line.substr(status_at, 3)));
      if (!openapi().at("paths").contains(route) || status == 204) continue;
      EXPECT_EQ(documented_statuses(route).count(status), 1u)
          << "openapi.json does not document " << status << " for " << route;
    }
  }

  const std::string gly_ = read_file(tracemesh::testing::molecule_path("gly.pqr"));
  fake_mesher mesher_;
  server_config config_;
  std::unique_ptr<service> service_;
  unsigned short port_ = 0;
};

}  // namespace tracemesh::server::test
