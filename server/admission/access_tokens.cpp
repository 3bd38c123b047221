#include "server/admission/access_tokens.hpp"

#include <openssl/crypto.h>
#include <openssl/rand.h>

#include <array>
#include <new>
#include <sstream>

#include "server/storage/content_hash.hpp"
#include "server/storage/detail/durable_file.hpp"
#include "server/http/detail/http_text.hpp"

namespace tracemesh::server {

namespace {

constexpr std::size_t min_bearer_token_length = 16;

/// A token file line or an Authorization value without its blanks (a line may end in CRLF).
std::string_view without_blanks(std::string_view text) { return detail::trim(text, " \t\r"); }

}  // namespace

std::string new_owner_token() {
  std::array<unsigned char, 32> bytes{};
  if (RAND_bytes(bytes.data(), static_cast<int>(bytes.size())) != 1) throw std::bad_alloc();  // no entropy: as OOM
  return to_hex(bytes.data(), bytes.size());
}

std::string token_digest(std::string_view token) { return sha256_hex(token); }

bool digests_equal(std::string_view a, std::string_view b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

result<bearer_tokens> bearer_tokens::from_file(const std::filesystem::path& path) {
  const std::optional<std::string> text = detail::read_whole_file(path);
  if (!text) return status(errc::io_error, "--auth-token-file " + path.string() + ": cannot be read");
  std::vector<std::string> tokens;
  std::istringstream lines(*text);
  std::string line;
  while (std::getline(lines, line)) {
    const std::string_view token = without_blanks(line);
    if (token.empty() || token.front() == '#') continue;
    if (token.size() < min_bearer_token_length) {
      return status(errc::invalid_input, "--auth-token-file " + path.string() + ": a token is shorter than " +
                                             std::to_string(min_bearer_token_length) + " characters");
    }
    tokens.emplace_back(token);
  }
  if (tokens.empty()) return status(errc::invalid_input, "--auth-token-file " + path.string() + ": holds no token");
  return from_tokens(tokens);
}

bearer_tokens bearer_tokens::from_tokens(const std::vector<std::string>& tokens) {
  bearer_tokens out;
  for (const std::string& token : tokens) out.digests_.push_back(token_digest(token));
  return out;
}

bool bearer_tokens::accepts(std::string_view authorization) const {
  constexpr std::string_view scheme = "Bearer ";
  if (authorization.size() <= scheme.size()) return false;
  // The scheme is case-insensitive (RFC 9110 §11.1).
  if (!detail::iequals(authorization.substr(0, scheme.size()), scheme)) return false;
  const std::string presented = token_digest(without_blanks(authorization.substr(scheme.size())));
  bool accepted = false;
  for (const std::string& digest : digests_) accepted = digests_equal(presented, digest) || accepted;
  return accepted;
}

}  // namespace tracemesh::server
