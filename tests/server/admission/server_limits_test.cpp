// Tests of server/admission/server_limits.hpp: the listen address syntax and the limits that follow from others.
#include "server/admission/server_limits.hpp"

#include <gtest/gtest.h>

namespace tracemesh::server {
namespace {

TEST(ServerLimits, UploadLimitFollowsTheAtomLimit) {
  const server_limits defaults;
  // A 90 MB PQR of a million atoms must fit by default; 2 M atoms give about 256 MB.
  EXPECT_GE(defaults.max_upload_bytes, 256'000'000u);
  EXPECT_EQ(defaults.max_upload_bytes, upload_limit_for_atoms(defaults.mesh.max_atoms));
  EXPECT_GT(upload_limit_for_atoms(1'000'000), 90'000'000u);
  EXPECT_LT(upload_limit_for_atoms(10), 1u << 20);
  EXPECT_EQ(defaults.max_header_bytes, 8192u);
}

TEST(ServerLimits, ParsesListenAddresses) {
  server_config config;
  EXPECT_TRUE(parse_listen_address("0.0.0.0:9000", config));
  EXPECT_EQ(config.listen_host, "0.0.0.0");
  EXPECT_EQ(config.listen_port, 9000);
  EXPECT_TRUE(parse_listen_address("[::1]:0", config));
  EXPECT_EQ(config.listen_host, "::1");
  EXPECT_EQ(config.listen_port, 0);
  for (const char* bad : {"", "8080", ":8080", "host:", "host:65536", "host:80x", "host:-1"}) {
    EXPECT_FALSE(parse_listen_address(bad, config)) << bad;
  }
}

TEST(ServerLimits, StartupJsonNamesEveryLimit) {
  server_config config;
  config.limits.max_queue = 7;
  const nlohmann::json json = config_to_json(config);
  EXPECT_EQ(json.at("max_queue"), 7);
  EXPECT_EQ(json.at("max_upload_bytes"), config.limits.max_upload_bytes);
  EXPECT_EQ(json.at("listen"), "127.0.0.1:8080");
  for (const char* key : {"max_atoms", "max_header_bytes", "max_connections", "job_timeout_s", "request_timeout_s",
                          "write_timeout_s", "linger_time_s", "header_timeout_s", "shutdown_grace_s",
                          "cache_disk_bytes", "redis_connect_timeout_ms", "redis_command_timeout_ms"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
}

}  // namespace
}  // namespace tracemesh::server
