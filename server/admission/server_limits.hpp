#pragma once
/// @file server_limits.hpp
/// Every limit of tracemeshd, named in one place with its safe default, and the rest of its configuration.
/// main() fills these from the command line and logs them at start-up as one JSON line (limits_to_json).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/limits.hpp"
#include "core/io/pqr_reader.hpp"
#include "server/admission/forwarded_client.hpp"

namespace tracemesh::server {

/// A PQR ATOM line is ~70–90 bytes; 128 bytes per atom leaves room for long names, serials and CRLF. The default
/// upload limit follows from the atom limit through this factor (2 M atoms → 256 MiB), so a 90 MB PQR of a million
/// atoms is accepted out of the box. Multipart framing adds well under one line per part.
inline constexpr std::uint64_t upload_bytes_per_atom = 128;

/// Upload limit implied by an atom limit (used unless --max-upload-bytes is given).
inline std::uint64_t upload_limit_for_atoms(std::size_t max_atoms) {
  return static_cast<std::uint64_t>(max_atoms) * upload_bytes_per_atom + 64 * 1024;
}

/// Timeouts and reconnect pacing of one Redis connection (server/redis/redis_client.hpp). A command runs on a worker
/// or prep thread, never on an I/O thread, so these bound how long such a thread can wait on Redis.
struct redis_limits {
  /// TCP connect (and name lookup) of one attempt.
  std::chrono::milliseconds connect_timeout{std::chrono::seconds(2)};
  /// Send and receive of one command; past it the connection is dropped and the command fails.
  std::chrono::milliseconds command_timeout{std::chrono::seconds(5)};
  /// After a failed command or connect, no new attempt for this long (doubled on each further failure up to
  /// reconnect_backoff_max, reset by a success): calls inside the window fail at once, so threads do not pile up
  /// on a dead Redis.
  std::chrono::milliseconds reconnect_backoff_initial{100};
  std::chrono::milliseconds reconnect_backoff_max{std::chrono::seconds(5)};
};

/// The replicas of `tracemeshd --store redis://…` (server/redis/redis_job_coordinator.hpp): how fast a dead
/// replica's job is taken over, and how often a live one says it is alive.
struct replica_limits {
  /// A job taken from the shared stream whose replica stopped renewing it for this long (it died) is reclaimed
  /// by another replica (XAUTOCLAIM), and its run lease (SET NX PX) expires after the same time
  /// (--reclaim-timeout). A kill -9'd replica's job is done within this plus its meshing time.
  std::chrono::milliseconds reclaim_timeout{std::chrono::seconds(30)};
  /// How often a replica renews its jobs' stream entries and run leases, publishes their progress to Redis,
  /// looks for owners' cancellations and checks that Redis answers (/readyz). Kept well under reclaim_timeout.
  std::chrono::milliseconds heartbeat{250};
  /// Longest wait of one XREADGROUP for new work (shorter than redis_limits::command_timeout).
  std::chrono::milliseconds take_block{1000};
  /// A replica asked for a job another replica is meshing (the run lease is held) looks this often whether it
  /// is done.
  std::chrono::milliseconds follow_poll{100};
  /// A replica with no free worker looks this often whether one is free before taking more work.
  std::chrono::milliseconds idle_poll{50};
  /// Pause after a failed Redis command of the consumer loop (the client's own backoff paces reconnects).
  std::chrono::milliseconds error_pause{200};
  /// An event stream (GET /jobs/{id}/events) of a job another replica runs reads the job's record when a message
  /// on the job-events channel (Redis pub/sub, server/redis/redis_job_events.hpp) says it changed, and at least
  /// this often otherwise, so a message lost while the subscriber reconnected delays an event by this much at most.
  std::chrono::milliseconds event_fallback{std::chrono::seconds(2)};
  /// Jobs whose latest change a replica's job-events subscriber remembers; past it the oldest is forgotten (its
  /// event streams then read the record once more). Finished jobs are forgotten at their final message.
  std::size_t max_event_jobs = 4096;
};

struct server_limits {
  /// Mesher limits (atoms, extent, lattice, triangles); max_atoms is --max-atoms.
  mesh_limits mesh;
  /// Request body bytes of POST /mesh and POST /jobs (--max-upload-bytes). Checked from Content-Length before any
  /// body byte is read (413, no 100 Continue), and while streaming for chunked bodies.
  std::uint64_t max_upload_bytes = upload_limit_for_atoms(mesh_limits{}.max_atoms);
  /// Decompressed PQR bytes of a gzipped upload (a gzip bomb stops here with 413); follows the atom limit as
  /// read_pqr_file does (core/pqr_reader.hpp: max_pqr_text_bytes).
  std::uint64_t max_pqr_bytes = max_pqr_text_bytes(mesh_limits{});
  /// Request body bytes of every other route (they take no body).
  std::uint64_t max_small_body_bytes = 64 * 1024;
  /// Request line + header fields; over it → 431 and the connection is closed.
  std::uint32_t max_header_bytes = 8 * 1024;
  /// Open connections. A connection over it makes the oldest idle keep-alive connection close; when none is idle
  /// it becomes a probe connection (health_connection_reserve): it may only ask /healthz or /readyz (anything else
  /// → 503 + Retry-After, then closed).
  std::size_t max_connections = 256;
  /// Probe connections: connections over max_connections or over their client's max_connections_per_client, kept
  /// open to read one request, answered only when it asks /healthz or /readyz, then closed. They are counted apart
  /// from max_connections and bounded by this (the fd budget is max_connections + this). A new probe over it makes
  /// the oldest probe that has not sent a byte close, so silent connections can never shut out a monitor's health
  /// check; with none silent, the new connection is answered 503 and closed without being read.
  std::size_t health_connection_reserve = 16;
  /// Header deadline of a probe connection: short, since a health check sends its request at once and a silent
  /// probe only holds a descriptor.
  std::chrono::milliseconds probe_header_timeout{std::chrono::seconds(2)};
  /// A failed accept (out of descriptors: EMFILE, ENFILE) is retried after this pause instead of at once, so the
  /// listener does not spin (and log) while the connection waits in the backlog.
  std::chrono::milliseconds accept_error_pause{100};
  /// GET /jobs/{id}/events streams open at once (--max-event-streams); over it → 503 + Retry-After. Each stream
  /// also holds one of max_connections (it is busy, never closed as idle), so this keeps room for other requests.
  std::size_t max_event_streams = 64;
  /// Event streams of one client (--max-event-streams-per-client); over it → 429 client_limit. Half of
  /// max_event_streams, as the other per-client limits: one client's streams never take every slot.
  std::size_t max_event_streams_per_client = 32;
  /// A client refused by a per-client limit is logged (warning) at most once per this interval, and at most
  /// max_refusal_log_clients clients are remembered for it (server/observability/log_throttle.hpp): refusals are
  /// cheap to provoke, the log must not be.
  std::chrono::milliseconds refusal_log_interval{std::chrono::minutes(1)};
  std::size_t max_refusal_log_clients = 1024;
  /// An event stream looks at its job this often: at most ~4 progress events per second.
  std::chrono::milliseconds event_interval{250};
  /// An event stream without events for this long sends a comment line (keeps proxies from closing it, and
  /// finds a client that went away).
  std::chrono::milliseconds event_keepalive{std::chrono::seconds(15)};
  /// Uploads being received or parsed at the same time (bounds upload memory); over it → 429 + Retry-After.
  /// A lab's burst of small uploads must pass: 20 concurrent clients are well within it.
  std::size_t max_concurrent_uploads = 64;
  /// Body bytes received by all uploads in flight together (counted as they arrive, never from a declared
  /// Content-Length: a client announcing 255 MB and sending nothing holds no budget); an upload whose next bytes
  /// do not fit → 429 + Retry-After and the connection is closed. Bounds upload memory where
  /// max_concurrent_uploads alone would allow 64 × max_upload_bytes. A lone upload always fits, so a value below
  /// max_upload_bytes serialises large uploads instead of refusing them.
  std::uint64_t max_upload_bytes_in_flight = 1ull << 30;
  /// Slow bodies (--min-upload-rate, --upload-rate-grace): after the grace time counted from the end of the
  /// header, an upload must have received at least min_upload_bytes_per_second × (elapsed − grace) bytes; one
  /// that falls behind is answered 408 (JSON body) and closed, freeing its upload slot. 0 disables the check
  /// (request_timeout still applies).
  std::uint64_t min_upload_bytes_per_second = 4 * 1024;
  std::chrono::milliseconds upload_rate_grace{std::chrono::seconds(10)};
  /// Uploads whose body exceeds this (and every Content-Encoding: gzip upload) are decoded and parsed on the
  /// large-upload pool (server_config::large_upload_threads), so that small uploads and cache reads on the prep
  /// pool never wait behind a big decompression or parse.
  std::uint64_t large_upload_bytes = 1024 * 1024;
  /// Per client (its bearer token when --auth-token-file is used, else its IP address): open connections
  /// (--max-connections-per-client; past it the connection may ask /healthz and /readyz, anything else → 429),
  /// uploads in flight (--max-uploads-per-client) and jobs queued or running that it submitted
  /// (--max-jobs-per-client); past a limit → 429 + Retry-After with a JSON body naming the limit. Each default is
  /// half its global limit (max_connections, max_concurrent_uploads, max_queue): one client never holds all.
  std::size_t max_connections_per_client = 128;
  std::size_t max_uploads_per_client = 32;
  std::size_t max_jobs_per_client = 32;
  /// Reverse proxies (--trusted-proxy): from a peer in these networks the client of the per-client limits, the
  /// access log and the refusal log is the one its Forwarded / X-Forwarded-For header names (forwarded_client.hpp);
  /// from anyone else those headers are ignored. A connection from a trusted proxy counts against the client of
  /// the request it carries, from that request's header to its response (its idle time belongs to the proxy).
  std::vector<ip_network> trusted_proxies;
  /// The small-job lane: jobs of at most this many atoms (--small-job-max-atoms) may also run on
  /// small_job_workers extra workers reserved for them, so a small molecule never waits behind big ones.
  std::size_t small_job_max_atoms = 20000;
  /// Non-file multipart fields (parameters) and parts per upload.
  std::size_t max_form_parts = 16;
  std::size_t max_form_field_bytes = 4096;
  /// Jobs waiting for a worker (--max-queue); over it → 429 + Retry-After.
  std::size_t max_queue = 64;
  /// Finished jobs whose status (done/failed/cancelled) is remembered for GET /jobs/{id}; done jobs stay visible
  /// through the cache after that.
  std::size_t max_job_records = 4096;
  /// Wall time of one job (--job-timeout); past it the job fails with "timeout" and is not cached.
  std::chrono::milliseconds job_timeout{std::chrono::minutes(10)};
  /// Time to receive a request's header block, counted from the connection's start or the previous response
  /// (keep-alive idle time and slow-header clients both end here).
  std::chrono::milliseconds header_timeout{std::chrono::seconds(30)};
  /// Whole-request deadline, header to last body byte (a slow body cannot hold a connection forever).
  std::chrono::milliseconds request_timeout{std::chrono::minutes(5)};
  /// Deadline of each response write (a client that never reads is dropped).
  std::chrono::milliseconds write_timeout{std::chrono::seconds(60)};
  /// After a response that closes the connection, what the client still sends (the rest of a refused upload) is
  /// read and dropped for at most this long, so that the client reads the response instead of a reset.
  std::chrono::milliseconds linger_time{std::chrono::seconds(2)};
  /// SIGTERM grace period: running and queued jobs may finish within it; what is left is cancelled.
  std::chrono::milliseconds shutdown_grace{std::chrono::seconds(20)};
  /// Retry-After (seconds) sent with 429 and 503.
  unsigned retry_after_seconds = 5;
  /// How long a finished job's record and mesh stay in the job store (--job-retention, seconds): GET /jobs/{id}
  /// and its mesh answer for this long after the job ended, whatever the result cache evicted.
  std::chrono::milliseconds job_retention{std::chrono::hours(24)};
  /// --no-disk-store only: bytes of meshes and reports the in-memory job store holds (--job-store-memory-bytes);
  /// past it the oldest finished jobs are forgotten.
  std::size_t job_store_memory_bytes = std::size_t{1} << 30;
  /// Result cache: memory LRU bytes and disk bytes (--cache-max-bytes).
  std::size_t cache_memory_bytes = 256u << 20;
  std::uint64_t cache_disk_bytes = 4ull << 30;
  /// The Redis connections of a replicated store (not used by the default local store).
  redis_limits redis;
  /// Reclaim, heartbeat and polling of a replicated store.
  replica_limits replicas;
};

struct server_config {
  std::string listen_host = "127.0.0.1";
  unsigned short listen_port = 8080;  ///< 0 = an ephemeral port (tests)
  unsigned workers = 2;               ///< jobs run at the same time (one per worker thread)
  unsigned mesher_threads = 0;        ///< threads inside one mesher run; 0 = all cores
  unsigned io_threads = 1;            ///< HTTP I/O threads (never mesh, never touch disk)
  unsigned prep_threads = 1;          ///< small uploads' parsing, hashing and disk cache reads
  /// Decompression and parsing of large or gzip-encoded uploads (limits.large_upload_bytes), apart from the prep
  /// pool; bounded, so at most this many big decodes run at once (the others wait in the pool's queue).
  unsigned large_upload_threads = 2;
  /// Workers reserved for small jobs (limits.small_job_max_atoms), in addition to `workers`; 0 = no lane.
  unsigned small_job_workers = 1;
  std::filesystem::path cache_dir;    ///< empty → memory-only cache
  /// --store: empty = this process alone (the job store below); "redis://HOST:PORT[/DB]" = one replica of many
  /// sharing records and work through Redis and results through cache_dir (a directory every replica mounts).
  std::string store_url;
  /// This replica's name in the Redis consumer group, the run leases and the metrics (--replica-name; default
  /// "<hostname>-<pid>"). Unique per running process.
  std::string replica_name;
  /// The job store (records, inputs of unfinished jobs, meshes); empty → in memory, nothing survives a restart
  /// (tracemeshd: --job-dir, default <cache-dir>/jobs; --no-disk-store empties both).
  std::filesystem::path job_dir;
  /// --auth-token-file: when set, every route but auth_exempt_routes needs "Authorization: Bearer <token>".
  std::filesystem::path auth_token_file;
  /// Routes answered without a bearer token (--auth-exempt); CORS preflights (OPTIONS) always are.
  std::vector<std::string> auth_exempt_routes{"/healthz", "/readyz", "/metrics"};
  std::vector<std::string> cors_origins{"*"};  ///< allowed Origins; "*" = any
  server_limits limits;
};

/// "host:port" → host and port into `config`; false when malformed (port not 0..65535, empty host).
bool parse_listen_address(const std::string& text, server_config& config);

/// One JSON object with every limit and setting, for the start-up log line.
nlohmann::json config_to_json(const server_config& config);

}  // namespace tracemesh::server
