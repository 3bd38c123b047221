#include "server/redis/redis_job_records.hpp"

#include <charconv>
#include <map>

#include <nlohmann/json.hpp>

#include "proto/api_types.hpp"
#include "proto/mesh_format.hpp"
#include "server/redis/redis_job_events.hpp"

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

// KEYS[1] record; ARGV stage, progress, eta_s, events channel, message. 0 when the record is gone (nothing
// written), 1 otherwise. The message is published when the stage or progress changed (not for the ETA alone).
constexpr const char* set_progress_script = R"lua(
if redis.call('EXISTS', KEYS[1]) == 0 then return 0 end
local old = redis.call('HMGET', KEYS[1], 'stage', 'progress')
redis.call('HSET', KEYS[1], 'stage', ARGV[1], 'progress', ARGV[2], 'eta_s', ARGV[3])
if old[1] ~= ARGV[1] or old[2] ~= ARGV[2] then redis.call('PUBLISH', ARGV[4], ARGV[5]) end
return 1
)lua";

// KEYS[1] record, KEYS[2] owners, KEYS[3] input, KEYS[4] stream; ARGV[1] group, ARGV[2] owner, ARGV[3] job id,
// ARGV[4] parameters, ARGV[5] format, ARGV[6] accepted_ms, ARGV[7] input bytes, ARGV[8] max waiting entries,
// ARGV[9] events channel, ARGV[10] message (published when accepted).
// {"coalesced"} | {"queue_full"} | {"accepted", entry id}.
constexpr const char* accept_script = R"lua(
local state = redis.call('HGET', KEYS[1], 'state')
if state == 'queued' or state == 'running' then
  redis.call('SADD', KEYS[2], ARGV[2])
  return {'coalesced'}
end
local waiting = redis.call('XLEN', KEYS[4]) - redis.call('XPENDING', KEYS[4], ARGV[1])[1]
if waiting >= tonumber(ARGV[8]) then return {'queue_full'} end
redis.call('DEL', KEYS[1], KEYS[2])
redis.call('HSET', KEYS[1], 'state', 'queued', 'parameters', ARGV[4], 'format', ARGV[5], 'error_code', '',
           'error_message', '', 'accepted_ms', ARGV[6], 'finished_ms', '0')
redis.call('SADD', KEYS[2], ARGV[2])
redis.call('SET', KEYS[3], ARGV[7])
local entry = redis.call('XADD', KEYS[4], '*', 'job', ARGV[3])
redis.call('HSET', KEYS[1], 'entry', entry)
redis.call('PUBLISH', ARGV[9], ARGV[10])
return {'accepted', entry}
)lua";

// KEYS[1] record; ARGV[1] replica, ARGV[2] now ms, ARGV[3] events channel, ARGV[4] message. 1 when the queued
// job is now running here, 0 otherwise.
constexpr const char* mark_running_script = R"lua(
local state = redis.call('HGET', KEYS[1], 'state')
if state ~= 'queued' and state ~= 'running' then return 0 end
redis.call('HSET', KEYS[1], 'state', 'running', 'replica', ARGV[1], 'started_ms', ARGV[2])
redis.call('PUBLISH', ARGV[3], ARGV[4])
return 1
)lua";

// KEYS[1] record, KEYS[2] owners, KEYS[3] input; ARGV[1] owner, ARGV[2] now ms, ARGV[3] expiry (Unix ms),
// ARGV[4] events channel, ARGV[5] message (published when a queued job is cancelled).
constexpr const char* withdraw_script = R"lua(
local state = redis.call('HGET', KEYS[1], 'state')
if not state then return 'not_found' end
if state ~= 'queued' and state ~= 'running' then return 'already_final' end
if redis.call('SREM', KEYS[2], ARGV[1]) == 0 then return 'not_owner' end
if redis.call('SCARD', KEYS[2]) > 0 then return 'withdrawn' end
if state == 'running' then
  redis.call('HSET', KEYS[1], 'cancel', '1')
  return 'cancelling'
end
redis.call('HSET', KEYS[1], 'state', 'cancelled', 'error_code', 'cancelled', 'error_message', 'cancelled by request',
           'finished_ms', ARGV[2])
redis.call('PEXPIREAT', KEYS[1], ARGV[3])
redis.call('DEL', KEYS[3])
redis.call('PUBLISH', ARGV[4], ARGV[5])
return 'cancelled'
)lua";

// KEYS[1] record; ARGV[1] field, ARGV[2] value. 1 when written (the job is done), 0 otherwise.
constexpr const char* set_encoding_script = R"lua(
if redis.call('HGET', KEYS[1], 'state') ~= 'done' then return 0 end
redis.call('HSET', KEYS[1], ARGV[1], ARGV[2])
return 1
)lua";

/// The prefix of a done job's encoding fields ("enc:off").
constexpr std::string_view encoding_field_prefix = "enc:";

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
  if (const std::string* report = field("report")) {
    std::string text = *report;
    for (const auto& [name, value] : fields) {
      if (name.rfind(encoding_field_prefix, 0) != 0) continue;
      const nlohmann::json entry = nlohmann::json::parse(value, nullptr, false);
      if (!entry.is_discarded()) text = with_encoding(text, name.substr(encoding_field_prefix.size()), entry);
    }
    record.report = std::make_shared<const std::string>(std::move(text));
  }
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
                                std::to_string(progress), eta_s ? std::to_string(*eta_s) : std::string(),
                                events_channel(), redis_job_events::message("running", id)});
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

namespace {

/// The error of a Redis reply that is not an integer (or an array when `array`).
status unexpected_reply(std::string_view what) {
  return status(errc::io_error, std::string("unexpected Redis reply to ").append(what));
}

}  // namespace

result<redis_job_records::accept_outcome> redis_job_records::accept_and_queue(const stored_job& record,
                                                                              const std::string& input_bytes,
                                                                              const std::string& stream_key,
                                                                              const std::string& group,
                                                                              std::size_t max_waiting) {
  if (record.owners.size() != 1) return status(errc::invalid_argument, "accept_and_queue takes exactly one owner");
  auto reply = client_.command({"EVAL", accept_script, "4", record_key(record.id), owners_key(record.id),
                                input_key(record.id), stream_key, group, record.owners.front(), record.id,
                                record.parameters, std::string(proto::format_name(record.format)),
                                std::to_string(record.accepted_ms), input_bytes, std::to_string(max_waiting),
                                events_channel(), redis_job_events::message("queued", record.id)});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a job's acceptance", *reply);
  if (reply->elements.empty()) return unexpected_reply("a job's acceptance");
  const std::string& outcome = reply->elements[0].text;
  if (outcome == "accepted") return accept_outcome::accepted;
  if (outcome == "coalesced") return accept_outcome::coalesced;
  if (outcome == "queue_full") return accept_outcome::queue_full;
  return unexpected_reply("a job's acceptance");
}

result<std::optional<std::string>> redis_job_records::input(const std::string& id) {
  auto reply = client_.command({"GET", input_key(id)});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("an input read", *reply);
  if (reply->is_nil()) return std::optional<std::string>{};
  return std::optional<std::string>(std::move(reply->text));
}

result<bool> redis_job_records::mark_running(const std::string& id, const std::string& replica) {
  auto reply = client_.command({"EVAL", mark_running_script, "1", record_key(id), replica,
                                std::to_string(unix_millis()), events_channel(),
                                redis_job_events::message("running", id)});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a job's start", *reply);
  return reply->integer == 1;
}

status redis_job_records::finish(const stored_job& record) {
  const std::string key = record_key(record.id);
  const std::string expires_at = std::to_string(record.finished_ms + retention_.count());
  std::vector<std::string> hset{"HSET",          key,
                                "state",         std::string(proto::job_state_name(record.state)),
                                "parameters",    record.parameters,
                                "format",        std::string(proto::format_name(record.format)),
                                "error_code",    record.error_code,
                                "error_message", record.error_message,
                                "accepted_ms",   std::to_string(record.accepted_ms),
                                "finished_ms",   std::to_string(record.finished_ms)};
  if (record.report) {
    hset.push_back("report");
    hset.push_back(*record.report);
  }
  auto replies = client_.pipeline({{"MULTI"},
                                   std::move(hset),
                                   {"HDEL", key, "cancel"},
                                   {"DEL", input_key(record.id)},
                                   {"PEXPIREAT", key, expires_at},
                                   {"PEXPIREAT", owners_key(record.id), expires_at},
                                   {"PUBLISH", events_channel(),
                                    redis_job_events::message(proto::job_state_name(record.state), record.id)},
                                   {"EXEC"}});
  if (!replies.ok()) return replies.error();
  if (const redis_reply* error = first_error(*replies)) return redis_refused("a job's final record", *error);
  if (replies->back().type != redis_reply::kind::array) return status(errc::io_error, "Redis aborted a job record write");
  return status::success();
}

result<redis_job_records::withdraw_outcome> redis_job_records::withdraw(const std::string& id,
                                                                        const std::string& owner_hash) {
  const std::int64_t now = unix_millis();
  auto reply = client_.command({"EVAL", withdraw_script, "3", record_key(id), owners_key(id), input_key(id),
                                owner_hash, std::to_string(now), std::to_string(now + retention_.count()),
                                events_channel(), redis_job_events::message("cancelled", id)});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a withdrawal", *reply);
  static constexpr std::pair<std::string_view, withdraw_outcome> outcomes[] = {
      {"not_found", withdraw_outcome::not_found},   {"already_final", withdraw_outcome::already_final},
      {"not_owner", withdraw_outcome::not_owner},   {"withdrawn", withdraw_outcome::withdrawn},
      {"cancelled", withdraw_outcome::cancelled},   {"cancelling", withdraw_outcome::cancelling}};
  for (const auto& [name, outcome] : outcomes) {
    if (reply->text == name) return outcome;
  }
  return unexpected_reply("a withdrawal");
}

result<bool> redis_job_records::cancel_requested(const std::string& id) {
  auto reply = client_.command({"HGET", record_key(id), "cancel"});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("a cancel check", *reply);
  return reply->text == "1";
}

status redis_job_records::set_encoding(const std::string& id, std::string_view format_name,
                                       const std::string& entry_json) {
  std::string field(encoding_field_prefix);
  field.append(format_name);
  auto reply = client_.command({"EVAL", set_encoding_script, "1", record_key(id), field, entry_json});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("an encoding's entry", *reply);
  if (reply->integer != 1) return status(errc::invalid_argument, std::string("no done job ").append(id));
  return status::success();
}

}  // namespace tracemesh::server
