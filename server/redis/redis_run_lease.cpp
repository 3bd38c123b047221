#include "server/redis/redis_run_lease.hpp"

namespace tracemesh::server {

namespace {

// KEYS[1] lease; ARGV[1] replica, ARGV[2] ttl in ms. 1 when extended, 0 when the lease is not this replica's.
constexpr const char* renew_script = R"lua(
if redis.call('GET', KEYS[1]) ~= ARGV[1] then return 0 end
return redis.call('PEXPIRE', KEYS[1], ARGV[2])
)lua";

// KEYS[1] lease; ARGV[1] replica. 1 when deleted, 0 when the lease is not this replica's.
constexpr const char* release_script = R"lua(
if redis.call('GET', KEYS[1]) ~= ARGV[1] then return 0 end
return redis.call('DEL', KEYS[1])
)lua";

status check_ttl(std::chrono::milliseconds ttl) {
  if (ttl.count() <= 0) return status(errc::invalid_argument, "a run lease needs a positive ttl");
  return status::success();
}

}  // namespace

redis_run_lease::redis_run_lease(redis_client& client, std::string replica, std::string key_prefix)
    : client_(client), replica_(std::move(replica)), prefix_(std::move(key_prefix)) {}

result<bool> redis_run_lease::acquire(const std::string& job_id, std::chrono::milliseconds ttl) {
  if (status valid = check_ttl(ttl); !valid.ok()) return valid;
  auto reply = client_.command({"SET", lease_key(job_id), replica_, "NX", "PX", std::to_string(ttl.count())});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("SET NX", *reply);
  return reply->is_status("OK");  // nil: held by someone
}

result<bool> redis_run_lease::renew(const std::string& job_id, std::chrono::milliseconds ttl) {
  if (status valid = check_ttl(ttl); !valid.ok()) return valid;
  auto reply = client_.command({"EVAL", renew_script, "1", lease_key(job_id), replica_, std::to_string(ttl.count())});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a lease renewal", *reply);
  return reply->integer == 1;
}

result<bool> redis_run_lease::release(const std::string& job_id) {
  auto reply = client_.command({"EVAL", release_script, "1", lease_key(job_id), replica_});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a lease release", *reply);
  return reply->integer == 1;
}

result<std::optional<std::string>> redis_run_lease::holder(const std::string& job_id) {
  auto reply = client_.command({"GET", lease_key(job_id)});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("GET", *reply);
  if (reply->is_nil()) return std::optional<std::string>{};
  return std::optional<std::string>(reply->text);
}

}  // namespace tracemesh::server
