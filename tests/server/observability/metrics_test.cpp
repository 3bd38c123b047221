// Tests of server/observability/metrics.hpp: the Prometheus text format rules the service promises (service-test-list 59).
#include "server/observability/metrics.hpp"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>
#include <string>

namespace tracemesh::server {
namespace {

/// name{labels} → value of every sample line; `typed` gets every family named by a # TYPE line.
std::map<std::string, double> samples(const std::string& text, std::set<std::string>& typed) {
  std::map<std::string, double> out;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("# TYPE ", 0) == 0) {
      typed.insert(line.substr(7, line.find(' ', 7) - 7));
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    const auto space = line.rfind(' ');
    const std::string key = line.substr(0, space);
    std::string family = key.substr(0, key.find('{'));
    for (const char* suffix : {"_bucket", "_sum", "_count"}) {
      const std::string s(suffix);
      if (family.size() > s.size() && family.compare(family.size() - s.size(), s.size(), s) == 0 &&
          typed.count(family.substr(0, family.size() - s.size())) != 0) {
        family = family.substr(0, family.size() - s.size());
      }
    }
    EXPECT_TRUE(typed.count(family)) << "sample before its # TYPE: " << line;
    out[key] = std::stod(line.substr(space + 1));
  }
  return out;
}

TEST(Metrics, CountsRequestsByRouteAndStatus) {
  metrics m;
  m.count_request("/mesh", 200);
  m.count_request("/mesh", 200);
  m.count_request("/mesh", 413);
  EXPECT_EQ(m.requests("/mesh", 200), 2u);
  EXPECT_EQ(m.requests("/mesh", 413), 1u);
  EXPECT_EQ(m.requests("/jobs", 200), 0u);
  std::set<std::string> typed;
  const auto values = samples(m.render({}), typed);
  EXPECT_EQ(values.at(R"(tracemesh_http_requests_total{route="/mesh",status="200"})"), 2);
  EXPECT_EQ(values.at(R"(tracemesh_http_requests_total{route="/mesh",status="413"})"), 1);
}

TEST(Metrics, HistogramBucketsAreCumulativeAndEndWithInfEqualToCount) {
  metrics m;
  for (double seconds : {0.001, 0.2, 0.2, 3.0, 1000.0}) m.count_job_finished("done", seconds);
  m.count_job_finished("failed", 0.02);
  std::set<std::string> typed;
  const auto values = samples(m.render({}), typed);
  double previous = 0;
  for (double bound : metrics::job_seconds_buckets) {
    std::ostringstream key;
    key << "tracemesh_job_seconds_bucket{le=\"" << bound << "\"}";
    ASSERT_TRUE(values.count(key.str())) << key.str();
    EXPECT_GE(values.at(key.str()), previous);
    previous = values.at(key.str());
  }
  EXPECT_EQ(values.at(R"(tracemesh_job_seconds_bucket{le="0.01"})"), 1);
  EXPECT_EQ(values.at(R"(tracemesh_job_seconds_bucket{le="0.25"})"), 4);
  EXPECT_EQ(values.at(R"(tracemesh_job_seconds_bucket{le="300"})"), 5);
  EXPECT_EQ(values.at(R"(tracemesh_job_seconds_bucket{le="+Inf"})"), 6);
  EXPECT_EQ(values.at("tracemesh_job_seconds_count"), 6);
  EXPECT_NEAR(values.at("tracemesh_job_seconds_sum"), 1003.421, 1e-9);
  EXPECT_EQ(values.at(R"(tracemesh_jobs_finished_total{state="done"})"), 5);
  EXPECT_TRUE(typed.count("tracemesh_job_seconds"));
}

TEST(Metrics, CountersEndInTotalAndGaugesComeFromTheCaller) {
  metrics m;
  m.count_mesher_run();
  m.count_mesher_run();
  m.count_trace_fallback();
  m.count_trace_grid_retries(2);
  m.count_trace_grid_retries(1);
  metrics_gauges gauges;
  gauges.queue_depth = 3;
  gauges.running_jobs = 1;
  gauges.cache_hits = 7;
  gauges.cache_disk_bytes = 12345;
  const std::string text = m.render(gauges);
  std::set<std::string> typed;
  const auto values = samples(text, typed);
  EXPECT_EQ(values.at("tracemesh_mesher_runs_total"), 2);
  EXPECT_EQ(m.mesher_runs(), 2u);
  EXPECT_EQ(values.at("tracemesh_trace_fallbacks_total"), 1);
  EXPECT_EQ(values.at("tracemesh_trace_grid_retries_total"), 3);
  EXPECT_EQ(values.at("tracemesh_queue_depth"), 3);
  EXPECT_EQ(values.at("tracemesh_running_jobs"), 1);
  EXPECT_EQ(values.at("tracemesh_cache_hits_total"), 7);
  EXPECT_EQ(values.at("tracemesh_cache_disk_bytes"), 12345);
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("# TYPE ", 0) == 0 && line.find(" counter") != std::string::npos) {
      const std::string name = line.substr(7, line.find(' ', 7) - 7);
      EXPECT_EQ(name.substr(name.size() - 6), "_total") << line;
    }
  }
}

}  // namespace
}  // namespace tracemesh::server
