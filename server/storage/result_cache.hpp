#pragma once
/// @file result_cache.hpp
/// Content-addressed result cache: a bounded in-memory LRU in front of a bounded on-disk store.
///
/// Keys are "<64 lower-case hex>.<suffix>" (suffix [a-z0-9_]{1,16}: "off", "drc", "report"...), optionally followed
/// by ".<coding>" ([a-z0-9_]{1,24}): a compressed representation of the entry without it ("<id>.off.br4w22_b1_0_9",
/// see content_coding.hpp). Because keys name
/// content, two writers of one key write the same bytes, and a put of a key already stored on disk is skipped.
///
/// Disk layout: <dir>/<first two hex digits>/<key>. Each file holds a header (magic, payload length, SHA-256 of
/// the payload, the key) and the payload. Writes go to a temporary file in the same directory, which is
/// fsync'd, renamed over the final name, and the directory fsync'd (ccache AtomicFile): a crash or SIGKILL at any
/// moment leaves either the whole entry or none. Writers hold an flock on their temporary file; open() removes
/// temporary files nobody holds (orphans of killed writers). Reads verify the header and the checksum; a
/// corrupt or truncated entry is removed and reported as a miss, never served.
///
/// Bounds: memory_bytes (sum of payload sizes held in memory) and disk_bytes (sum of entry file sizes), each
/// enforced by evicting the least recently used entries (get and put count as uses). An entry larger than a
/// tier's bound is not kept in that tier. Several processes may share a directory; each bounds what it knows.
///
/// Threading: every member is thread-safe. Memory and disk have separate mutexes, and no mutex is held while an
/// entry's bytes are read, written or hashed (only metadata operations — rename, unlink — run under the disk
/// index mutex, to keep the index and the directory consistent). Disk I/O happens on the calling thread: call
/// get()/put() from worker threads, and get_from_memory() where blocking is not allowed.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

#include "core/status.hpp"

namespace tracemesh::server {

struct cache_limits {
  std::size_t memory_bytes = 256u << 20;    ///< payload bytes held in memory
  std::uint64_t disk_bytes = 4ull << 30;    ///< entry file bytes (header included) on disk
};

struct cache_stats {
  std::uint64_t hits;             ///< get() answered from memory or disk
  std::uint64_t misses;           ///< get() answered nullptr (including corrupt entries and read errors)
  std::uint64_t memory_bytes;     ///< payload bytes now in memory
  std::uint64_t disk_bytes;       ///< entry file bytes now on disk (as indexed by this process)
  std::uint64_t entries;          ///< distinct keys now held (memory or disk)
  std::uint64_t corrupt_entries;  ///< disk entries found corrupt or truncated, and removed
  std::uint64_t evictions;        ///< entries evicted from memory or disk to respect the bounds
  std::uint64_t write_failures;   ///< put() calls that failed on disk I/O
};

/// True iff `key` is "<64 lower-case hex>.<suffix>" with suffix [a-z0-9_]{1,16}, optionally followed by
/// ".<coding>" with coding [a-z0-9_]{1,24}.
bool is_valid_cache_key(std::string_view key);

class result_cache {
 public:
  /// @param dir     cache directory; empty → memory only (open() is then a no-op).
  /// @param limits  the memory and disk bounds.
  result_cache(std::filesystem::path dir, cache_limits limits);
  ~result_cache();
  result_cache(const result_cache&) = delete;
  result_cache& operator=(const result_cache&) = delete;

  /// Creates the directory, removes orphan temporary files, indexes the existing entries (by modification time,
  /// oldest first, for LRU) and evicts the oldest if they exceed disk_bytes. Entries are verified lazily by
  /// get(). Until open() succeeds the cache works in memory only.
  /// @return errc::io_error when the directory cannot be created, is not a directory or is not writable (a probe
  ///         file is written, fsync'd and removed).
  status open();

  /// Called (on the thread of get()) for every corrupt or truncated entry found, with its key and why; set before
  /// the cache is shared between threads. The service logs these at error level.
  void set_corruption_listener(std::function<void(const std::string& key, const char* reason)> listener) {
    on_corrupt_ = std::move(listener);
  }

  /// The entry's bytes, or nullptr on a miss (unknown or invalid key, corrupt entry — then removed —, read
  /// error). A disk hit is promoted to memory. The returned bytes stay valid even if the entry is evicted.
  std::shared_ptr<const std::string> get(const std::string& key);
  /// Like get() but never touches the disk: safe on threads that must not block. Counts hits only (a caller
  /// that falls back to get() on nullptr gets the miss counted there, so each lookup counts once).
  std::shared_ptr<const std::string> get_from_memory(const std::string& key);

  /// Stores `bytes` under `key`: on disk first (atomic), then in memory. A key already on disk is not rewritten.
  /// @return errc::invalid_argument for an invalid key; errc::limit_exceeded when the entry exceeds every
  ///         tier's bound (nothing is stored); errc::io_error when the disk write fails — then nothing is
  ///         stored anywhere and no temporary file is left.
  status put(const std::string& key, std::string_view bytes);

  cache_stats stats() const;

  /// Fault injection (Beast test::fail_count style; tests only): the Nth counted disk I/O operation from now on
  /// (1-based; open, mkdir, write, fsync, close, rename, read...) fails as if the disk had returned EIO.
  /// Clean-up after a failure is never failed. std::nullopt disables injection.
  void set_fault_injection(std::optional<std::size_t> fail_on_nth_io_operation);

  const std::filesystem::path& directory() const noexcept { return dir_; }
  const cache_limits& limits() const noexcept { return limits_; }

 private:
  struct memory_entry {
    std::string key;
    std::shared_ptr<const std::string> bytes;
  };
  struct disk_entry {
    std::string key;
    std::uint64_t file_bytes;
  };
  using memory_list = std::list<memory_entry>;  // most recently used first
  using disk_list = std::list<disk_entry>;      // most recently used first

  bool disk_enabled() const;
  std::filesystem::path entry_path(const std::string& key) const;
  bool io_step_fails();

  void remember_in_memory(const std::string& key, std::shared_ptr<const std::string> bytes);
  std::shared_ptr<const std::string> find_in_memory(const std::string& key);

  bool disk_entry_present(const std::string& key);
  void touch_disk_entry(const std::string& key);
  std::shared_ptr<const std::string> read_from_disk(const std::string& key);
  status write_to_disk(const std::string& key, std::string_view bytes);
  status publish_temp_file(const std::string& key, const std::filesystem::path& temp,
                           std::uint64_t file_bytes);
  void index_disk_entry_locked(const std::string& key, std::uint64_t file_bytes);
  void forget_disk_entry_locked(const std::string& key);
  void evict_disk_locked();
  void remove_corrupt_entry(const std::string& key, std::uint64_t device, std::uint64_t inode);
  void index_existing_entries();

  std::filesystem::path dir_;
  cache_limits limits_;
  std::function<void(const std::string&, const char*)> on_corrupt_;

  mutable std::mutex memory_mutex_;
  memory_list memory_lru_;
  std::unordered_map<std::string, memory_list::iterator> memory_index_;
  std::uint64_t memory_bytes_ = 0;

  mutable std::mutex disk_mutex_;
  bool disk_open_ = false;
  disk_list disk_lru_;
  std::unordered_map<std::string, disk_list::iterator> disk_index_;
  std::uint64_t disk_bytes_ = 0;

  std::atomic<std::uint64_t> hits_{0};
  std::atomic<std::uint64_t> misses_{0};
  std::atomic<std::uint64_t> corrupt_entries_{0};
  std::atomic<std::uint64_t> evictions_{0};
  std::atomic<std::uint64_t> write_failures_{0};
  std::atomic<std::uint64_t> temp_sequence_{0};

  // Fault injection: fail when io_operations_ reaches fail_on_io_operation_ (0 = never).
  std::atomic<std::uint64_t> io_operations_{0};
  std::atomic<std::uint64_t> fail_on_io_operation_{0};
};

}  // namespace tracemesh::server
