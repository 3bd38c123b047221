#pragma once
/// @file client_quota.hpp
/// A per-client count with a bound: how many connections, uploads or jobs one client (its bearer token's digest,
/// or its IP address) holds at the same time. A client over its bound is refused (429) while others go on.
///
/// acquire() hands out a lease that counts one use until it is destroyed; leases may be released on any thread and
/// may outlive the quota. A client's entry is removed when its last lease goes, so the map stays as small as the
/// set of active clients. Thread-safe.

#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace tracemesh::server {

class client_lease;

class client_quota {
 public:
  /// @param max_per_client  uses one client may hold at once (0 refuses every use)
  explicit client_quota(std::size_t max_per_client);

  /// One use by `client`, or nullptr when it already holds max_per_client.
  std::shared_ptr<client_lease> acquire(const std::string& client);
  /// Uses `client` holds now.
  std::size_t held(const std::string& client) const;
  std::size_t limit() const noexcept { return state_->max_per_client; }

 private:
  friend class client_lease;
  struct state {
    std::size_t max_per_client;
    mutable std::mutex mutex;
    std::unordered_map<std::string, std::size_t> held;
  };
  std::shared_ptr<state> state_;
};

/// One use counted against a client; released by the destructor.
class client_lease {
 public:
  ~client_lease();
  client_lease(const client_lease&) = delete;
  client_lease& operator=(const client_lease&) = delete;

 private:
  friend class client_quota;
  client_lease(std::shared_ptr<client_quota::state> owner, std::string client);

  std::shared_ptr<client_quota::state> owner_;
  const std::string client_;
};

}  // namespace tracemesh::server
