#pragma once
/// @file upload_admission.hpp
/// Admission control for uploads: bounds how many uploads are in flight (being received, parsed or prepared) and
/// how many body bytes they hold together, so a burst of large uploads cannot exhaust memory.
///
/// An upload asks for a ticket when its header arrives, reserving no bytes: its reservation grows with the bytes
/// actually received (reserve_total), never from a declared Content-Length, so clients that announce large bodies
/// and send nothing hold no budget. The ticket holds the reservation until the last owner drops it (as soon as
/// the upload has been parsed, before any reply).
///
/// One upload is always admitted when none is in flight, whatever its size: the byte bound may then be smaller
/// than the per-upload limit without making large uploads impossible (they are simply served one at a time).
/// Thread-safe; tickets may be released on any thread and may outlive the upload_admission object.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <utility>

namespace tracemesh::server {

class upload_ticket;

class upload_admission {
 public:
  /// @param max_uploads  uploads in flight at the same time (≥ 1 is sensible; 0 refuses every upload)
  /// @param max_bytes    body bytes reserved by all uploads in flight together
  upload_admission(std::size_t max_uploads, std::uint64_t max_bytes);

  /// A ticket reserving `declared_bytes` (0 when unknown), or nullptr when max_uploads are in flight, or the bytes
  /// do not fit next to those already reserved, or none is left (refuse with 429 + Retry-After).
  std::shared_ptr<upload_ticket> admit(std::uint64_t declared_bytes);

  std::size_t uploads_in_flight() const;
  std::uint64_t bytes_in_flight() const;

 private:
  friend class upload_ticket;
  struct state {
    std::size_t max_uploads;
    std::uint64_t max_bytes;
    mutable std::mutex mutex;
    std::size_t uploads = 0;
    std::uint64_t bytes = 0;
  };
  std::shared_ptr<state> state_;
};

/// One admitted upload's reservation; released by the destructor.
class upload_ticket {
 public:
  ~upload_ticket();
  upload_ticket(const upload_ticket&) = delete;
  upload_ticket& operator=(const upload_ticket&) = delete;

  /// Raises the reservation to `total_bytes` (a chunked body that has received that many bytes so far).
  /// Never lowers it. False, reservation unchanged, when the new total does not fit next to the other uploads'
  /// (a lone upload always fits: its size is bounded by the per-upload limit instead).
  bool reserve_total(std::uint64_t total_bytes);
  std::uint64_t reserved_bytes() const;
  /// Keeps `companion` (the client's per-client upload lease) until the ticket is released.
  void attach(std::shared_ptr<void> companion) { companion_ = std::move(companion); }

 private:
  friend class upload_admission;
  upload_ticket(std::shared_ptr<upload_admission::state> owner, std::uint64_t bytes);

  std::shared_ptr<upload_admission::state> owner_;
  std::uint64_t bytes_;  // guarded by owner_->mutex
  std::shared_ptr<void> companion_;
};

}  // namespace tracemesh::server
