#include "server/redis/redis_job_records.hpp"

#include <charconv>
#include <map>

#include "proto/api_types.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::server {

namespace {

// KEYS[1] record, KEYS[2] owners; ARGV[1] owner hash. -1 when the record is gone, else SADD's count; the owners
// set takes the record's expiry (none while unfinished).
constexpr const char* add_owner_script = R"lua(
if redis.call('EXISTS', KEYS[1]) == 0 then return -1 end
local added = redis.call('SADD', KEYS[2], ARGV[1])
local ttl = redis.call('PTTL', KEYS[1])
if ttl > 0 then redis.call('PEXPIRE', KEYS[2], ttl) end
return added
)lua";

// KEYS[1] record; ARGV stage, progress, eta_s. 0 when the record is gone (nothing written), 1 otherwise.
constexpr const char* set_progress_script = R"lua(
if redis.call('EXISTS', KEYS[1]) == 0 then return 0 end
redis.call('HSET', KEYS[1], 'stage', ARGV[1], 'progress', ARGV[2], 'eta_s', ARGV[3])
return 1
)lua";

status malformed(const std::string& key, std::string_view why) {
  std::string message = "malformed job record ";
  message.append(key).append(" in Redis: ").append(why);
  return status(errc::io_error, std::move(message));
}

std::optional<std::int64_t> parse_int64(const std::string& text) {
  std::int64_t value = 0;
  const char* last = text.data() + text.size();
  const auto [end, error] = std::from_chars(text.data(), last, value);
  if (text.empty() || error != std::errc{} || end != last) return std::nullopt;
  return value;
}

/// HGETALL's flat [field, value, field, value...] as a map.
std::map<std::string, std::string> hash_fields(const redis_reply& reply) {
  std::map<std::string, std::string> fields;
  for (std::size_t i = 0; i + 1 < reply.elements.size(); i += 2) {
    fields[reply.elements[i].text] = reply.elements[i + 1].text;
  }
  return fields;
}

/// The first Redis error reply of a batch, or of an EXEC reply's elements; nullptr when there is none.
const redis_reply* first_error(const std::vector<redis_reply>& replies) {
  for (const redis_reply& reply : replies) {
    if (reply.is_error()) return &reply;
    if (reply.type == redis_reply::kind::array) {
      if (const redis_reply* inner = first_error(reply.elements)) return inner;
    }
  }
  return nullptr;
}

}  // namespace

redis_job_records::redis_job_records(redis_client& client, std::chrono::milliseconds retention,
                                     std::string key_prefix)
    : client_(client), retention_(retention), prefix_(std::move(key_prefix)) {}

status redis_job_records::put(const stored_job& record) {
  const std::string key = record_key(record.id);
  const std::string owners = owners_key(record.id);
  std::vector<std::string> hset{"HSET",
                                key,
                                "state",
                                std::string(proto::job_state_name(record.state)),
                                "parameters",
                                record.parameters,
                                "format",
                                std::string(proto::format_name(record.format)),
                                "error_code",
                                record.error_code,
                                "error_message",
                                record.error_message,
                                "accepted_ms",
                                std::to_string(record.accepted_ms),
                                "finished_ms",
                                std::to_string(record.finished_ms)};
  if (record.report) {
    hset.push_back("report");
    hset.push_back(*record.report);
  }
  std::vector<std::vector<std::string>> batch{{"MULTI"}, {"DEL", key, owners}, std::move(hset)};
  if (!record.owners.empty()) {
    std::vector<std::string> sadd{"SADD", owners};
    sadd.insert(sadd.end(), record.owners.begin(), record.owners.end());
    batch.push_back(std::move(sadd));
  }
  if (record.finished_ms > 0) {
    const std::string expires_at = std::to_string(record.finished_ms + retention_.count());
    batch.push_back({"PEXPIREAT", key, expires_at});
    batch.push_back({"PEXPIREAT", owners, expires_at});
  }
  batch.push_back({"EXEC"});
  auto replies = client_.pipeline(batch);
  if (!replies.ok()) return replies.error();
  if (const redis_reply* error = first_error(*replies)) return redis_refused("a job record write", *error);
  if (replies->back().type != redis_reply::kind::array) return status(errc::io_error, "Redis aborted a job record write");
  return status::success();
}

result<std::optional<stored_job>> redis_job_records::find(const std::string& id) {
  const std::string key = record_key(id);
  auto replies = client_.pipeline({{"HGETALL", key}, {"SMEMBERS", owners_key(id)}});
  if (!replies.ok()) return replies.error();
  if (const redis_reply* error = first_error(*replies)) return redis_refused("a job record read", *error);
  const auto fields = hash_fields((*replies)[0]);
  if (fields.empty()) return std::optional<stored_job>{};

  const auto field = [&](const char* name) -> const std::string* {
    const auto it = fields.find(name);
    return it == fields.end() ? nullptr : &it->second;
  };
  for (const char* name : {"state", "parameters", "format", "error_code", "error_message", "accepted_ms",
                           "finished_ms"}) {
    if (field(name) == nullptr) return malformed(key, std::string("no field ").append(name));
  }
  stored_job record;
  record.id = id;
  result<job_state> state = proto::parse_job_state(*field("state"));
  result<proto::mesh_format> format = proto::parse_mesh_format(*field("format"));
  const auto accepted = parse_int64(*field("accepted_ms"));
  const auto finished = parse_int64(*field("finished_ms"));
  if (!state.ok() || !format.ok() || !accepted || !finished) return malformed(key, "bad state, format or time");
  record.state = *state;
  record.format = *format;
  record.parameters = *field("parameters");
  record.error_code = *field("error_code");
  record.error_message = *field("error_message");
  record.accepted_ms = *accepted;
  record.finished_ms = *finished;
  if (const std::string* report = field("report")) record.report = std::make_shared<const std::string>(*report);
  for (const redis_reply& owner : (*replies)[1].elements) record.owners.push_back(owner.text);
  return std::optional<stored_job>(std::move(record));
}

status redis_job_records::add_owner(const std::string& id, const std::string& owner_hash) {
  auto reply = client_.command({"EVAL", add_owner_script, "2", record_key(id), owners_key(id), owner_hash});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("an owner update", *reply);
  if (reply->integer < 0) {
    return status(errc::invalid_argument, std::string("job ").append(id).append(" is unknown or expired"));
  }
  return status::success();
}

result<bool> redis_job_records::remove_owner(const std::string& id, const std::string& owner_hash) {
  auto reply = client_.command({"SREM", owners_key(id), owner_hash});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("an owner update", *reply);
  return reply->integer > 0;
}

result<bool> redis_job_records::set_progress(const std::string& id, std::string_view stage, double progress,
                                             std::optional<double> eta_s) {
  auto reply = client_.command({"EVAL", set_progress_script, "1", record_key(id), std::string(stage),
                                std::to_string(progress), eta_s ? std::to_string(*eta_s) : std::string()});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a progress update", *reply);
  return reply->integer == 1;
}

result<std::optional<redis_job_records::live_fields>> redis_job_records::find_progress(const std::string& id) {
  auto reply = client_.command({"HMGET", record_key(id), "state", "stage", "progress", "eta_s"});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a progress read", *reply);
  if (reply->elements.size() != 4 || reply->elements[0].is_nil()) return std::optional<live_fields>{};
  return std::optional<live_fields>(
      live_fields{reply->elements[1].text, reply->elements[2].text, reply->elements[3].text});
}

}  // namespace tracemesh::server
