#include "server/jobs/job_id.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>

#include "proto/api_types.hpp"
#include "server/storage/content_hash.hpp"

namespace tracemesh::server {

namespace {

/// Accumulates little-endian fields and feeds them to SHA-256 in blocks.
class canonical_writer {
 public:
  explicit canonical_writer(sha256& hash) : hash_(hash) { block_.reserve(block_bytes); }

  void text(std::string_view bytes) {
    flush();
    hash_.update(bytes);
  }
  void u64(std::uint64_t value) {
    for (int i = 0; i < 8; ++i) block_.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
    if (block_.size() >= block_bytes) flush();
  }
  // -0.0 and 0.0 describe the same geometry: hash one spelling of zero.
  void f64(double value) { u64(std::bit_cast<std::uint64_t>(value == 0.0 ? 0.0 : value)); }
  void flush() {
    hash_.update(block_);
    block_.clear();
  }

 private:
  static constexpr std::size_t block_bytes = 64 * 1024;
  sha256& hash_;
  std::string block_;
};

}  // namespace

std::string compute_job_id(const molecule& mol, const mesh_params& params) {
  sha256 hash;
  canonical_writer out(hash);
  out.text(std::string_view("tracemesh-job-v3\0", 17));
  out.text(engine_version);
  out.text(std::string_view("\0", 1));
  out.u64(mol.atoms.size());
  for (const atom& a : mol.atoms) {
    out.f64(a.center.x);
    out.f64(a.center.y);
    out.f64(a.center.z);
    out.f64(a.radius);
  }
  out.text(proto::canonical_parameters(params));
  out.flush();
  return hash.hex_digest();
}

std::string mesh_key(const std::string& job_id, proto::mesh_format format) {
  std::string suffix(proto::format_name(format));
  std::replace(suffix.begin(), suffix.end(), '-', '_');  // cache keys allow [a-z0-9_] after the dot
  return job_id + "." + suffix;
}

}  // namespace tracemesh::server
