#pragma once
/// @file content_hash.hpp
/// SHA-256 content hashing (OpenSSL EVP) and the job-id syntax check.
/// Job ids and cache keys are SHA-256 digests in lower-case hex, so one helper validates both before any
/// filesystem path is built from them.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace tracemesh::server {

/// Incremental SHA-256. Not thread-safe; one instance per stream of bytes.
/// Allocation failure inside OpenSSL throws std::bad_alloc (like any allocation); no other failure is possible
/// for an in-memory digest.
class sha256 {
 public:
  static constexpr std::size_t digest_size = 32;
  using digest = std::array<std::uint8_t, digest_size>;

  sha256();
  ~sha256();
  sha256(sha256&&) noexcept;
  sha256& operator=(sha256&&) noexcept;
  sha256(const sha256&) = delete;
  sha256& operator=(const sha256&) = delete;

  /// Append bytes to the message.
  void update(std::string_view bytes);
  /// Digest of every byte given since construction or the last finish()/hex_digest(); resets for reuse.
  digest finish();
  /// finish() as 64 lower-case hex characters.
  std::string hex_digest();

 private:
  struct context_deleter {
    void operator()(void* context) const noexcept;
  };
  std::unique_ptr<void, context_deleter> context_;  // EVP_MD_CTX, kept opaque to spare users OpenSSL headers
};

/// SHA-256 of `bytes` as 64 lower-case hex characters.
std::string sha256_hex(std::string_view bytes);

/// Lower-case hex of arbitrary bytes (two characters per byte).
std::string to_hex(const std::uint8_t* bytes, std::size_t size);

/// True iff `id` matches ^[0-9a-f]{64}$ (a SHA-256 hex digest). Anything else — upper case, "../", NUL,
/// percent-escapes, Unicode look-alikes, other lengths — is rejected before it can reach a file path.
bool is_valid_job_id(std::string_view id);

}  // namespace tracemesh::server
