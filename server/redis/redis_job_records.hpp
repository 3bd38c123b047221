#pragma once
/// @file redis_job_records.hpp
/// Job records in Redis, shared by every replica of `tracemeshd --store redis://…` (issue 13), so GET /jobs/{id},
/// DELETE and the event stream answer the same through any replica.
///
/// One job = two keys under a prefix (default "tracemesh:"):
///   <prefix>job:<id>          hash: state, parameters, format, error_code, error_message, report (done jobs),
///                             accepted_ms, finished_ms (the fields of stored_job), and the live fields stage,
///                             progress, eta_s written by set_progress while the job runs;
///   <prefix>job:<id>:owners   set: SHA-256 hex of each owner token still holding the job;
///   <prefix>input:<id>        string: the parsed input of an unfinished job (serialize_molecule), dropped at its end.
/// Writes that change what an event stream shows also PUBLISH "<state> <id>" on events_channel() (see
/// redis_job_events.hpp).
/// A done job's report gets one `enc:<format>` field per encoding made, merged into report.encodings by find().
/// Retention is Redis expiry: a finished record (finished_ms > 0) expires at finished_ms + retention (PEXPIREAT on
/// both keys), an unfinished one never does. Every write is one MULTI/EXEC transaction or one Lua script, so a
/// reader on another replica never sees half a record, and writes to a job that has expired never recreate it.
///
/// The result bytes are not here: they stay in the content-addressed disk store on a directory all replicas
/// mount (server/storage/result_cache.hpp, detail/durable_file.hpp).

#include <chrono>
#include <cstddef>
#include <string_view>
#include <optional>
#include <string>

#include "core/status.hpp"
#include "server/storage/job_store.hpp"
#include "server/redis/redis_client.hpp"

namespace tracemesh::server {

class redis_job_records {
 public:
  /// `client` must outlive this object; `retention` is --job-retention.
  redis_job_records(redis_client& client, std::chrono::milliseconds retention, std::string key_prefix = "tracemesh:");

  /// Writes the whole record (replacing any previous one, its live fields and owners included) and its expiry.
  /// @return errc::io_error when Redis is unreachable or refused the transaction.
  status put(const stored_job& record);
  /// The record, or std::nullopt when unknown or expired. errc::io_error when Redis is unreachable or the stored
  /// hash is not a record this version wrote (a field missing or malformed).
  result<std::optional<stored_job>> find(const std::string& id);
  /// Adds an owner to an existing record (its set gets the record's expiry). errc::invalid_argument when the job
  /// is unknown or expired.
  status add_owner(const std::string& id, const std::string& owner_hash);
  /// Removes an owner; false when it was not one.
  result<bool> remove_owner(const std::string& id, const std::string& owner_hash);
  /// Live fields of a running job (proto stage name, progress 0..1, eta in seconds or nullopt = unknown); no-op
  /// for an unknown or expired job (false), so a late progress report never recreates a purged record.
  result<bool> set_progress(const std::string& id, std::string_view stage, double progress,
                            std::optional<double> eta_s);
  /// The live fields as last written (empty strings when never written; eta_s "" = unknown).
  struct live_fields {
    std::string stage;
    std::string progress;
    std::string eta_s;
  };
  result<std::optional<live_fields>> find_progress(const std::string& id);

  /// How accept_and_queue() went.
  enum class accept_outcome { accepted, coalesced, queue_full };
  /// POST /jobs on a replica, atomically (one Lua script): a job queued or running anywhere gets the owner added
  /// (coalesced); else, unless `max_waiting` entries of `stream_key` wait undelivered (queue_full), the record is
  /// written anew (state queued, the owner), the input stored under input_key, and the job appended to the stream
  /// (its entry id kept in the record's `entry` field). `record.owners` must hold exactly the submitting owner.
  result<accept_outcome> accept_and_queue(const stored_job& record, const std::string& input_bytes,
                                          const std::string& stream_key, const std::string& group,
                                          std::size_t max_waiting);
  /// The input stored by accept_and_queue(); std::nullopt when gone.
  result<std::optional<std::string>> input(const std::string& id);
  /// A queued job starts on `replica`: state running, `replica` and `started_ms` set. False when the job is not
  /// queued any more (final, unknown, or already running elsewhere: then only `replica` changes hands).
  result<bool> mark_running(const std::string& id, const std::string& replica);
  /// A final state (done, failed, cancelled), its error, report and finished_ms written over the record's fields,
  /// keeping its owners and encodings; the input is dropped and the record and owners expire after retention. A
  /// record that does not exist is created (a synchronous job's). errc::io_error when Redis is unreachable.
  status finish(const stored_job& record);
  /// DELETE by an owner, atomically: see withdraw_outcome. A running job gets its `cancel` field set, which its
  /// replica sees at its next heartbeat (cancel_requested()).
  enum class withdraw_outcome { not_found, already_final, not_owner, withdrawn, cancelled, cancelling };
  result<withdraw_outcome> withdraw(const std::string& id, const std::string& owner_hash);
  /// True when an owner's DELETE asked the running job to stop.
  result<bool> cancel_requested(const std::string& id);
  /// report.encodings.<format_name> = entry for a done job (a hash field of its own, merged into the report by
  /// find(), so concurrent writers never lose one another). errc::invalid_argument when the job is not done.
  status set_encoding(const std::string& id, std::string_view format_name, const std::string& entry_json);

  std::string record_key(const std::string& id) const { return prefix_ + "job:" + id; }
  std::string input_key(const std::string& id) const { return prefix_ + "input:" + id; }
  std::string owners_key(const std::string& id) const { return record_key(id) + ":owners"; }
  /// The pub/sub channel every write that changes what an event stream shows publishes on, in the same script or
  /// transaction (see redis_job_events.hpp).
  std::string events_channel() const { return prefix_ + "job-events"; }

 private:
  redis_client& client_;
  const std::chrono::milliseconds retention_;
  const std::string prefix_;
};

}  // namespace tracemesh::server
