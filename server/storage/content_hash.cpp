#include "server/storage/content_hash.hpp"

#include <openssl/evp.h>

#include <new>

namespace tracemesh::server {
namespace {

EVP_MD_CTX* as_context(void* context) { return static_cast<EVP_MD_CTX*>(context); }

// OpenSSL only fails here on allocation failure (or a broken provider setup), which we treat like std::bad_alloc.
void check(int openssl_result) {
  if (openssl_result != 1) throw std::bad_alloc();
}

void start_digest(void* context) { check(EVP_DigestInit_ex(as_context(context), EVP_sha256(), nullptr)); }

}  // namespace

void sha256::context_deleter::operator()(void* context) const noexcept { EVP_MD_CTX_free(as_context(context)); }

sha256::sha256() : context_(EVP_MD_CTX_new()) {
  if (!context_) throw std::bad_alloc();
  start_digest(context_.get());
}

sha256::~sha256() = default;
sha256::sha256(sha256&&) noexcept = default;
sha256& sha256::operator=(sha256&&) noexcept = default;

void sha256::update(std::string_view bytes) {
  check(EVP_DigestUpdate(as_context(context_.get()), bytes.data(), bytes.size()));
}

sha256::digest sha256::finish() {
  digest result{};
  unsigned int length = 0;
  check(EVP_DigestFinal_ex(as_context(context_.get()), result.data(), &length));
  if (length != result.size()) throw std::bad_alloc();  // cannot happen for SHA-256
  start_digest(context_.get());
  return result;
}

std::string sha256::hex_digest() {
  const digest bytes = finish();
  return to_hex(bytes.data(), bytes.size());
}

std::string sha256_hex(std::string_view bytes) {
  sha256 hasher;
  hasher.update(bytes);
  return hasher.hex_digest();
}

std::string to_hex(const std::uint8_t* bytes, std::size_t size) {
  static constexpr char digits[] = "0123456789abcdef";
  std::string hex(size * 2, '\0');
  for (std::size_t i = 0; i < size; ++i) {
    hex[2 * i] = digits[bytes[i] >> 4];
    hex[2 * i + 1] = digits[bytes[i] & 0x0f];
  }
  return hex;
}

bool is_valid_job_id(std::string_view id) {
  if (id.size() != 2 * sha256::digest_size) return false;
  for (const char c : id) {
    const bool hex_digit = (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
    if (!hex_digit) return false;
  }
  return true;
}

}  // namespace tracemesh::server
