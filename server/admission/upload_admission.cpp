#include "server/admission/upload_admission.hpp"

#include <utility>

namespace tracemesh::server {

upload_admission::upload_admission(std::size_t max_uploads, std::uint64_t max_bytes)
    : state_(std::make_shared<state>()) {
  state_->max_uploads = max_uploads;
  state_->max_bytes = max_bytes;
}

std::shared_ptr<upload_ticket> upload_admission::admit(std::uint64_t declared_bytes) {
  std::lock_guard lock(state_->mutex);
  if (state_->uploads >= state_->max_uploads) return nullptr;
  const bool alone = state_->uploads == 0;
  // A lone chunked upload may have grown past max_bytes: compare before subtracting (no unsigned wrap-around).
  // No room at all refuses even an upload of unknown size (it would be refused at its first bytes).
  const bool fits = state_->bytes < state_->max_bytes && declared_bytes <= state_->max_bytes - state_->bytes;
  if (!alone && !fits) return nullptr;
  ++state_->uploads;
  state_->bytes += declared_bytes;
  return std::shared_ptr<upload_ticket>(new upload_ticket(state_, declared_bytes));
}

std::size_t upload_admission::uploads_in_flight() const {
  std::lock_guard lock(state_->mutex);
  return state_->uploads;
}

std::uint64_t upload_admission::bytes_in_flight() const {
  std::lock_guard lock(state_->mutex);
  return state_->bytes;
}

upload_ticket::upload_ticket(std::shared_ptr<upload_admission::state> owner, std::uint64_t bytes)
    : owner_(std::move(owner)), bytes_(bytes) {}

upload_ticket::~upload_ticket() {
  std::lock_guard lock(owner_->mutex);
  --owner_->uploads;
  owner_->bytes -= bytes_;
}

bool upload_ticket::reserve_total(std::uint64_t total_bytes) {
  std::lock_guard lock(owner_->mutex);
  if (total_bytes <= bytes_) return true;
  const std::uint64_t others = owner_->bytes - bytes_;
  const bool alone = owner_->uploads == 1;
  const bool fits = others <= owner_->max_bytes && total_bytes <= owner_->max_bytes - others;
  if (!alone && !fits) return false;
  owner_->bytes = others + total_bytes;
  bytes_ = total_bytes;
  return true;
}

std::uint64_t upload_ticket::reserved_bytes() const {
  std::lock_guard lock(owner_->mutex);
  return bytes_;
}

}  // namespace tracemesh::server
