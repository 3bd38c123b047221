// Fuzz target for the Redis URL parser (server::parse_redis_url, `tracemeshd --store redis://…`).
// Checks, beyond "no crash": an accepted URL has a host and a port 1..65535, and its canonical spelling (to_url)
// parses back to the very same endpoint; a refused one names the expected form.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "server/redis/redis_url.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto endpoint = tracemesh::server::parse_redis_url(text);
  if (!endpoint.ok()) {
    if (endpoint.error().message().find("redis://HOST:PORT[/DB]") == std::string::npos) std::abort();
    return 0;
  }
  if (endpoint->host.empty() || endpoint->port == 0 || endpoint->db > tracemesh::server::max_redis_db_index) {
    std::abort();
  }
  const auto again = tracemesh::server::parse_redis_url(endpoint->to_url());
  if (!again.ok() || again->host != endpoint->host || again->port != endpoint->port || again->db != endpoint->db) {
    std::abort();
  }
  return 0;
}
