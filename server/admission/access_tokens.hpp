#pragma once
/// @file access_tokens.hpp
/// Secrets of the API: job owner tokens (returned when a job is created, needed to DELETE it) and the optional
/// bearer tokens of --auth-token-file. Only SHA-256 digests of tokens are kept (in memory and in the job store),
/// and presented tokens are compared digest to digest in constant time (CRYPTO_memcmp).

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.hpp"

namespace tracemesh::server {

/// A new owner token: 32 random bytes (OpenSSL RAND_bytes) as 64 lower-case hex characters.
std::string new_owner_token();

/// The digest under which a token is kept: SHA-256 as 64 lower-case hex characters.
std::string token_digest(std::string_view token);

/// Constant-time equality of two digests (false when their lengths differ).
bool digests_equal(std::string_view a, std::string_view b);

/// The bearer tokens a server accepts (Authorization: Bearer <token>).
class bearer_tokens {
 public:
  bearer_tokens() = default;
  /// One token per line; blank lines and lines starting with '#' are skipped; surrounding spaces are trimmed.
  /// @return errc::io_error when the file cannot be read; errc::invalid_input when it holds no token or a token
  ///         shorter than 16 characters (too easy to guess).
  static result<bearer_tokens> from_file(const std::filesystem::path& path);
  static bearer_tokens from_tokens(const std::vector<std::string>& tokens);

  bool enabled() const noexcept { return !digests_.empty(); }
  std::size_t size() const noexcept { return digests_.size(); }
  /// True when `authorization` (the header's value) is "Bearer <token>" with one of the tokens. Every token's
  /// digest is compared, so the time taken does not depend on which one matched.
  bool accepts(std::string_view authorization) const;

 private:
  std::vector<std::string> digests_;
};

}  // namespace tracemesh::server
