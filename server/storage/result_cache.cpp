#include "server/storage/result_cache.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <utility>
#include <vector>

#include "server/storage/content_hash.hpp"
#include "server/storage/detail/durable_file.hpp"

namespace tracemesh::server {
namespace {

namespace fs = std::filesystem;
using detail::fsync_directory;
using detail::open_retrying;
using detail::write_all;

// ---- Entry file format ------------------------------------------------------------------------------------
// magic (8) | payload length, u64 little-endian (8) | SHA-256 of the payload (32) | key length, u32 LE (4) | key
// | payload. Every header field is checked against what the reader expects, and the checksum covers the payload.
constexpr std::string_view entry_magic = "tmcache1";
constexpr std::size_t fixed_header_bytes = 8 + 8 + sha256::digest_size + 4;
constexpr std::size_t max_suffix_length = 16;
constexpr std::size_t max_coding_length = 24;
constexpr std::string_view temp_prefix = ".tmp-";
// A temporary file can be removed by another process's open() before its writer locks it (see write_to_disk);
// each such loss costs one more attempt. Losing this many in a row means something else is deleting our files.
constexpr int max_temp_file_attempts = 4;

std::uint64_t entry_file_bytes(const std::string& key, std::size_t payload_bytes) {
  return fixed_header_bytes + key.size() + payload_bytes;
}

void append_little_endian(std::string& out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

std::uint64_t read_little_endian(const char* in, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value |= std::uint64_t{static_cast<unsigned char>(in[i])} << (8 * i);
  return value;
}

std::string encode_header(const std::string& key, std::string_view payload) {
  sha256 hasher;
  hasher.update(payload);
  const sha256::digest checksum = hasher.finish();
  std::string header(entry_magic);
  append_little_endian(header, payload.size(), 8);
  header.append(reinterpret_cast<const char*>(checksum.data()), checksum.size());
  append_little_endian(header, key.size(), 4);
  header += key;
  return header;
}

/// Parsed header: the payload length and checksum, when the magic and the key match.
struct entry_header {
  std::uint64_t payload_bytes = 0;
  sha256::digest checksum{};
};

std::optional<entry_header> decode_header(std::string_view header, const std::string& key) {
  if (header.size() != fixed_header_bytes + key.size()) return std::nullopt;
  if (header.substr(0, entry_magic.size()) != entry_magic) return std::nullopt;
  entry_header parsed;
  parsed.payload_bytes = read_little_endian(header.data() + 8, 8);
  std::memcpy(parsed.checksum.data(), header.data() + 16, parsed.checksum.size());
  if (read_little_endian(header.data() + 16 + sha256::digest_size, 4) != key.size()) return std::nullopt;
  if (header.substr(fixed_header_bytes) != key) return std::nullopt;
  return parsed;
}

// ---- POSIX helpers -----------------------------------------------------------------------------------------

/// An owned file descriptor.
class unique_fd {
 public:
  explicit unique_fd(int fd = -1) : fd_(fd) {}
  ~unique_fd() { reset(); }
  unique_fd(unique_fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  unique_fd& operator=(unique_fd&& other) noexcept {
    if (this != &other) {
      reset();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  unique_fd(const unique_fd&) = delete;
  unique_fd& operator=(const unique_fd&) = delete;

  int get() const noexcept { return fd_; }
  explicit operator bool() const noexcept { return fd_ >= 0; }
  void reset() noexcept {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_;
};

/// True while the open file still has a name (nobody unlinked it since it was opened).
bool is_linked(int fd) {
  struct stat info {};
  return ::fstat(fd, &info) == 0 && info.st_nlink > 0;
}

enum class read_outcome { complete, short_file, error };

read_outcome read_all(int fd, char* out, std::size_t size) {
  while (size > 0) {
    const ssize_t got = ::read(fd, out, size);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return read_outcome::error;
    if (got == 0) return read_outcome::short_file;
    out += got;
    size -= static_cast<std::size_t>(got);
  }
  return read_outcome::complete;
}

status io_failure(std::string_view what, const fs::path& path, int error_number) {
  return status(errc::io_error, "result cache: " + std::string(what) + " " + path.string() + ": " +
                                    (error_number ? std::strerror(error_number) : "injected fault"));
}

bool is_hex_digit(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); }

bool is_shard_name(const std::string& name) {
  return name.size() == 2 && is_hex_digit(name[0]) && is_hex_digit(name[1]);
}

/// Removes a temporary file when no writer holds its lock (the writer died: the kernel released its flock).
void remove_if_orphan(const fs::path& temp) {
  const unique_fd fd(open_retrying(temp.c_str(), O_RDONLY));
  if (!fd) return;
  if (::flock(fd.get(), LOCK_EX | LOCK_NB) == 0) ::unlink(temp.c_str());
}

}  // namespace

namespace {

bool is_key_word(std::string_view text, std::size_t max_length) {
  if (text.empty() || text.size() > max_length) return false;
  for (const char c : text) {
    const bool allowed = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
    if (!allowed) return false;
  }
  return true;
}

}  // namespace

bool is_valid_cache_key(std::string_view key) {
  constexpr std::size_t hash_length = 2 * sha256::digest_size;
  if (key.size() < hash_length + 2) return false;
  if (!is_valid_job_id(key.substr(0, hash_length)) || key[hash_length] != '.') return false;
  const std::string_view rest = key.substr(hash_length + 1);
  const auto dot = rest.find('.');
  if (dot == std::string_view::npos) return is_key_word(rest, max_suffix_length);
  // A compressed representation: the key of its bytes plus its coding tag.
  return is_key_word(rest.substr(0, dot), max_suffix_length) && is_key_word(rest.substr(dot + 1), max_coding_length);
}

result_cache::result_cache(std::filesystem::path dir, cache_limits limits) : dir_(std::move(dir)), limits_(limits) {}

result_cache::~result_cache() = default;

status result_cache::open() {
  if (dir_.empty()) return status::success();
  // A read-only or unusable directory is an error here, not a cache that silently never stores (issue 12, 1).
  if (const status usable = detail::ensure_writable_directory(dir_, "cache directory"); !usable.ok()) return usable;
  {
    std::lock_guard lock(disk_mutex_);
    disk_lru_.clear();
    disk_index_.clear();
    disk_bytes_ = 0;
  }
  index_existing_entries();
  std::lock_guard lock(disk_mutex_);
  evict_disk_locked();
  disk_open_ = true;
  return status::success();
}

// Lists <dir>/<shard>/*: removes orphan temporary files, indexes entry files oldest first.
void result_cache::index_existing_entries() {
  struct found_entry {
    std::string key;
    std::uint64_t file_bytes;
    fs::file_time_type modified;
  };
  std::vector<found_entry> found;
  std::error_code error;
  for (fs::directory_iterator shard(dir_, error), end; !error && shard != end; shard.increment(error)) {
    const std::string shard_name = shard->path().filename().string();
    std::error_code type_error;
    if (!is_shard_name(shard_name) || !shard->is_directory(type_error)) continue;
    std::error_code inner_error;
    for (fs::directory_iterator file(shard->path(), inner_error); !inner_error && file != end;
         file.increment(inner_error)) {
      const std::string name = file->path().filename().string();
      if (name.rfind(temp_prefix, 0) == 0) {
        remove_if_orphan(file->path());
        continue;
      }
      if (!is_valid_cache_key(name) || name.compare(0, 2, shard_name) != 0) continue;
      std::error_code stat_error;
      const std::uint64_t size = file->file_size(stat_error);
      const fs::file_time_type modified = file->last_write_time(stat_error);
      if (!stat_error) found.push_back({name, size, modified});
    }
  }
  std::sort(found.begin(), found.end(), [](const found_entry& a, const found_entry& b) {
    return a.modified != b.modified ? a.modified < b.modified : a.key < b.key;
  });
  std::lock_guard lock(disk_mutex_);
  for (const found_entry& entry : found) index_disk_entry_locked(entry.key, entry.file_bytes);
}

bool result_cache::disk_enabled() const {
  std::lock_guard lock(disk_mutex_);
  return disk_open_;
}

std::filesystem::path result_cache::entry_path(const std::string& key) const {
  return dir_ / key.substr(0, 2) / key;
}

bool result_cache::io_step_fails() {
  const std::uint64_t fail_on = fail_on_io_operation_.load();
  const std::uint64_t operation = io_operations_.fetch_add(1) + 1;
  return fail_on != 0 && operation == fail_on;
}

void result_cache::set_fault_injection(std::optional<std::size_t> fail_on_nth_io_operation) {
  io_operations_.store(0);
  fail_on_io_operation_.store(fail_on_nth_io_operation.value_or(0));
}

// ---- get ---------------------------------------------------------------------------------------------------

std::shared_ptr<const std::string> result_cache::get_from_memory(const std::string& key) {
  if (!is_valid_cache_key(key)) return nullptr;
  auto bytes = find_in_memory(key);
  if (bytes) {
    hits_.fetch_add(1);
    touch_disk_entry(key);
  }
  return bytes;
}

std::shared_ptr<const std::string> result_cache::get(const std::string& key) {
  if (!is_valid_cache_key(key)) {
    misses_.fetch_add(1);
    return nullptr;
  }
  if (auto bytes = find_in_memory(key)) {
    hits_.fetch_add(1);
    touch_disk_entry(key);
    return bytes;
  }
  auto bytes = disk_enabled() ? read_from_disk(key) : nullptr;
  if (!bytes) {
    misses_.fetch_add(1);
    return nullptr;
  }
  hits_.fetch_add(1);
  remember_in_memory(key, bytes);
  return bytes;
}

std::shared_ptr<const std::string> result_cache::find_in_memory(const std::string& key) {
  std::lock_guard lock(memory_mutex_);
  const auto found = memory_index_.find(key);
  if (found == memory_index_.end()) return nullptr;
  memory_lru_.splice(memory_lru_.begin(), memory_lru_, found->second);
  return found->second->bytes;
}

void result_cache::remember_in_memory(const std::string& key, std::shared_ptr<const std::string> bytes) {
  if (bytes->size() > limits_.memory_bytes) return;
  std::lock_guard lock(memory_mutex_);
  if (const auto found = memory_index_.find(key); found != memory_index_.end()) {
    memory_bytes_ -= found->second->bytes->size();
    memory_lru_.erase(found->second);
    memory_index_.erase(found);
  }
  memory_bytes_ += bytes->size();
  memory_lru_.push_front({key, std::move(bytes)});
  memory_index_[key] = memory_lru_.begin();
  while (memory_bytes_ > limits_.memory_bytes) {
    const memory_entry& victim = memory_lru_.back();
    memory_bytes_ -= victim.bytes->size();
    memory_index_.erase(victim.key);
    memory_lru_.pop_back();
    evictions_.fetch_add(1);
  }
}

// Reads and verifies an entry file. Corrupt entries are removed; read errors leave the file alone.
std::shared_ptr<const std::string> result_cache::read_from_disk(const std::string& key) {
  const fs::path path = entry_path(key);
  if (io_step_fails()) return nullptr;
  const unique_fd fd(open_retrying(path.c_str(), O_RDONLY));
  if (!fd) {
    if (errno == ENOENT) {
      std::lock_guard lock(disk_mutex_);
      forget_disk_entry_locked(key);
    }
    return nullptr;
  }
  struct stat info {};
  if (::fstat(fd.get(), &info) != 0) return nullptr;
  const auto corrupt = [&](const char* reason) {
    remove_corrupt_entry(key, info.st_dev, info.st_ino);
    if (on_corrupt_) on_corrupt_(key, reason);
    return nullptr;
  };

  std::string header(fixed_header_bytes + key.size(), '\0');
  if (io_step_fails()) return nullptr;
  const read_outcome header_read = read_all(fd.get(), header.data(), header.size());
  if (header_read == read_outcome::error) return nullptr;
  if (header_read == read_outcome::short_file) return corrupt("truncated header");
  const std::optional<entry_header> parsed = decode_header(header, key);
  const auto file_bytes = static_cast<std::uint64_t>(info.st_size);
  if (!parsed || file_bytes < header.size() || file_bytes - header.size() != parsed->payload_bytes) {
    return corrupt("bad header or size");
  }

  auto payload = std::make_shared<std::string>(parsed->payload_bytes, '\0');
  if (io_step_fails()) return nullptr;
  const read_outcome payload_read = read_all(fd.get(), payload->data(), payload->size());
  if (payload_read == read_outcome::error) return nullptr;
  if (payload_read == read_outcome::short_file) return corrupt("truncated payload");
  sha256 hasher;
  hasher.update(*payload);
  if (hasher.finish() != parsed->checksum) return corrupt("checksum mismatch");

  ::futimens(fd.get(), nullptr);  // last use survives restarts (LRU order); best effort
  // Index the entry unless it was evicted (unlinked) while we read it: the bytes are still good to serve.
  if (is_linked(fd.get())) {
    std::lock_guard lock(disk_mutex_);
    index_disk_entry_locked(key, file_bytes);
    evict_disk_locked();
  }
  return payload;
}

// Unlinks a corrupt entry unless a writer has meanwhile replaced it with a new file (another inode).
void result_cache::remove_corrupt_entry(const std::string& key, std::uint64_t device, std::uint64_t inode) {
  corrupt_entries_.fetch_add(1);
  const fs::path path = entry_path(key);
  std::lock_guard lock(disk_mutex_);
  struct stat info {};
  if (::stat(path.c_str(), &info) == 0 && info.st_dev == device && info.st_ino == inode) ::unlink(path.c_str());
  forget_disk_entry_locked(key);
}

// ---- put ---------------------------------------------------------------------------------------------------

status result_cache::put(const std::string& key, std::string_view bytes) {
  if (!is_valid_cache_key(key)) return status(errc::invalid_argument, "result cache: invalid key");
  const bool fits_memory = bytes.size() <= limits_.memory_bytes;
  const bool fits_disk = disk_enabled() && entry_file_bytes(key, bytes.size()) <= limits_.disk_bytes;
  if (!fits_memory && !fits_disk) {
    return status(errc::limit_exceeded, "result cache: entry of " + std::to_string(bytes.size()) +
                                            " bytes exceeds the cache bounds");
  }
  if (fits_disk && !disk_entry_present(key)) {
    const status written = write_to_disk(key, bytes);
    if (!written.ok()) {
      write_failures_.fetch_add(1);
      return written;
    }
  }
  if (fits_memory) remember_in_memory(key, std::make_shared<const std::string>(bytes));
  return status::success();
}

// Temporary file, flock, header + payload, fsync, then publish (rename + directory fsync).
status result_cache::write_to_disk(const std::string& key, std::string_view bytes) {
  const fs::path shard = dir_ / key.substr(0, 2);
  if (io_step_fails()) return io_failure("mkdir", shard, 0);
  if (::mkdir(shard.c_str(), 0755) != 0 && errno != EEXIST) return io_failure("mkdir", shard, errno);

  fs::path temp;
  unique_fd fd;
  const auto abandon = [&](std::string_view what, int error_number) {
    fd.reset();
    ::unlink(temp.c_str());
    return io_failure(what, temp, error_number);
  };
  for (int attempt = 1;; ++attempt) {
    temp = shard / (std::string(temp_prefix) + key + "-" + std::to_string(::getpid()) + "-" +
                    std::to_string(temp_sequence_.fetch_add(1)));
    if (io_step_fails()) return io_failure("create", temp, 0);
    fd = unique_fd(open_retrying(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644));
    if (!fd) return io_failure("create", temp, errno);
    // The lock marks the file as live: open() in any process removes only temporary files nobody holds. It waits:
    // an open() elsewhere holds a temporary file's lock only while it removes the file.
    if (::flock(fd.get(), LOCK_EX) != 0) return abandon("lock", errno);
    if (is_linked(fd.get())) break;
    // An open() in another process found the file between its creation and the lock, took it for a dead writer's
    // and removed it. Start again under a new name.
    if (attempt == max_temp_file_attempts) return abandon("lock", ENOENT);
  }
  const std::string header = encode_header(key, bytes);
  if (io_step_fails()) return abandon("write", 0);
  if (!write_all(fd.get(), header)) return abandon("write", errno);
  if (io_step_fails()) return abandon("write", 0);
  if (!write_all(fd.get(), bytes)) return abandon("write", errno);
  if (io_step_fails()) return abandon("fsync", 0);
  if (::fsync(fd.get()) != 0) return abandon("fsync", errno);

  const status published = publish_temp_file(key, temp, header.size() + bytes.size());
  fd.reset();
  if (!published.ok()) ::unlink(temp.c_str());
  return published;
}

// Renames the complete temporary file over the entry and makes the rename durable. On failure the entry is not
// visible afterwards (a rename whose directory fsync failed is undone).
status result_cache::publish_temp_file(const std::string& key, const fs::path& temp, std::uint64_t file_bytes) {
  const fs::path path = entry_path(key);
  {
    std::lock_guard lock(disk_mutex_);
    if (io_step_fails()) return io_failure("rename", temp, 0);
    if (::rename(temp.c_str(), path.c_str()) != 0) return io_failure("rename", temp, errno);
    index_disk_entry_locked(key, file_bytes);
    evict_disk_locked();
  }
  const auto undo = [&](int error_number) {
    std::lock_guard lock(disk_mutex_);
    ::unlink(path.c_str());
    forget_disk_entry_locked(key);
    return io_failure("fsync directory of", path, error_number);
  };
  if (io_step_fails()) return undo(0);
  if (!fsync_directory(path.parent_path())) return undo(errno);
  return status::success();
}

// ---- disk index --------------------------------------------------------------------------------------------

// True when the entry is indexed and its file is still there with the indexed size (nobody removed it behind
// our back). Content addressing makes a present entry as good as a fresh write.
bool result_cache::disk_entry_present(const std::string& key) {
  std::uint64_t indexed_bytes = 0;
  {
    std::lock_guard lock(disk_mutex_);
    const auto found = disk_index_.find(key);
    if (found == disk_index_.end()) return false;
    indexed_bytes = found->second->file_bytes;
  }
  struct stat info {};
  return ::stat(entry_path(key).c_str(), &info) == 0 && static_cast<std::uint64_t>(info.st_size) == indexed_bytes;
}

void result_cache::touch_disk_entry(const std::string& key) {
  std::lock_guard lock(disk_mutex_);
  const auto found = disk_index_.find(key);
  if (found != disk_index_.end()) disk_lru_.splice(disk_lru_.begin(), disk_lru_, found->second);
}

void result_cache::index_disk_entry_locked(const std::string& key, std::uint64_t file_bytes) {
  forget_disk_entry_locked(key);
  disk_lru_.push_front({key, file_bytes});
  disk_index_[key] = disk_lru_.begin();
  disk_bytes_ += file_bytes;
}

void result_cache::forget_disk_entry_locked(const std::string& key) {
  const auto found = disk_index_.find(key);
  if (found == disk_index_.end()) return;
  disk_bytes_ -= found->second->file_bytes;
  disk_lru_.erase(found->second);
  disk_index_.erase(found);
}

// Unlinks least recently used entries until the disk bound holds. Runs under disk_mutex_ so that a concurrent
// put of the same key cannot have its fresh file unlinked by a stale decision.
void result_cache::evict_disk_locked() {
  while (disk_bytes_ > limits_.disk_bytes && !disk_lru_.empty()) {
    const disk_entry& victim = disk_lru_.back();
    ::unlink(entry_path(victim.key).c_str());
    disk_bytes_ -= victim.file_bytes;
    disk_index_.erase(victim.key);
    disk_lru_.pop_back();
    evictions_.fetch_add(1);
  }
}

cache_stats result_cache::stats() const {
  cache_stats result{};
  result.hits = hits_.load();
  result.misses = misses_.load();
  result.corrupt_entries = corrupt_entries_.load();
  result.evictions = evictions_.load();
  result.write_failures = write_failures_.load();
  std::lock_guard memory_lock(memory_mutex_);  // lock order: memory, then disk
  std::lock_guard disk_lock(disk_mutex_);
  result.memory_bytes = memory_bytes_;
  result.disk_bytes = disk_bytes_;
  result.entries = disk_index_.size();
  for (const memory_entry& entry : memory_lru_) {
    if (disk_index_.count(entry.key) == 0) ++result.entries;
  }
  return result;
}

}  // namespace tracemesh::server
