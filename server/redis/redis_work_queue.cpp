#include "server/redis/redis_work_queue.hpp"

namespace tracemesh::server {

namespace {

/// Stream entries [[id, [field, value, ...]], ...] as queue entries; entries deleted meanwhile (nil fields, as
/// XAUTOCLAIM may return in Redis 7) and entries without a job field are skipped.
std::vector<queue_entry> entries_of(const redis_reply& list) {
  std::vector<queue_entry> entries;
  for (const redis_reply& entry : list.elements) {
    if (entry.elements.size() != 2) continue;
    const redis_reply& fields = entry.elements[1];
    for (std::size_t i = 0; i + 1 < fields.elements.size(); i += 2) {
      if (fields.elements[i].text == "job") {
        entries.push_back({entry.elements[0].text, fields.elements[i + 1].text});
        break;
      }
    }
  }
  return entries;
}

}  // namespace

redis_work_queue::redis_work_queue(redis_client& client, std::string replica, std::string key_prefix)
    : client_(client), replica_(std::move(replica)), prefix_(std::move(key_prefix)) {}

status redis_work_queue::ensure_group() {
  // Start id 0: entries pushed before the group existed are delivered too.
  auto reply = client_.command({"XGROUP", "CREATE", stream_key(), group, "0", "MKSTREAM"});
  if (!reply.ok()) return reply.error();
  if (reply->is_error() && reply->text.rfind("BUSYGROUP", 0) != 0) return redis_refused("XGROUP CREATE", *reply);
  return status::success();
}

result<std::string> redis_work_queue::push(const std::string& job_id) {
  auto reply = client_.command({"XADD", stream_key(), "*", "job", job_id});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("XADD", *reply);
  return reply->text;
}

result<std::vector<queue_entry>> redis_work_queue::take(std::size_t count, std::chrono::milliseconds block) {
  // A BLOCK as long as the command timeout would look like a dead connection and drop it.
  if (block.count() < 0 || block >= client_.limits().command_timeout || count == 0) {
    return status(errc::invalid_argument, "take() needs count > 0 and 0 <= block < the Redis command timeout");
  }
  std::vector<std::string> arguments{"XREADGROUP", "GROUP", group, replica_, "COUNT", std::to_string(count)};
  if (block.count() > 0) {  // BLOCK 0 would wait forever
    arguments.push_back("BLOCK");
    arguments.push_back(std::to_string(block.count()));
  }
  arguments.insert(arguments.end(), {"STREAMS", stream_key(), ">"});
  auto reply = client_.command(arguments);
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("XREADGROUP", *reply);
  // nil on timeout; else [[stream, [entries]]].
  if (reply->is_nil() || reply->elements.empty() || reply->elements[0].elements.size() != 2) {
    return std::vector<queue_entry>{};
  }
  return entries_of(reply->elements[0].elements[1]);
}

status redis_work_queue::ack(const std::string& entry_id) {
  auto replies = client_.pipeline({{"XACK", stream_key(), group, entry_id}, {"XDEL", stream_key(), entry_id}});
  if (!replies.ok()) return replies.error();
  for (const redis_reply& reply : *replies) {
    if (reply.is_error()) return redis_refused("XACK", reply);
  }
  return status::success();
}

result<bool> redis_work_queue::touch(const std::string& entry_id) {
  auto reply = client_.command({"XCLAIM", stream_key(), group, replica_, "0", entry_id, "JUSTID"});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("XCLAIM", *reply);
  return !reply->elements.empty();
}

result<std::vector<queue_entry>> redis_work_queue::reclaim(std::chrono::milliseconds min_idle, std::size_t count) {
  auto reply = client_.command({"XAUTOCLAIM", stream_key(), group, replica_, std::to_string(min_idle.count()), "0",
                                "COUNT", std::to_string(count)});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("XAUTOCLAIM", *reply);
  // [next cursor, [entries], [deleted ids]] (Redis ≥ 7).
  if (reply->elements.size() < 2) return std::vector<queue_entry>{};
  return entries_of(reply->elements[1]);
}

result<std::size_t> redis_work_queue::pending() {
  auto reply = client_.command({"XPENDING", stream_key(), group});
  if (!reply.ok()) return reply.error();
  if (reply->is_error()) return redis_refused("XPENDING", *reply);
  if (reply->elements.empty()) return std::size_t{0};
  return static_cast<std::size_t>(reply->elements[0].integer);
}

}  // namespace tracemesh::server
