#include "server/admission/client_quota.hpp"

#include <utility>

namespace tracemesh::server {

client_quota::client_quota(std::size_t max_per_client) : state_(std::make_shared<state>()) {
  state_->max_per_client = max_per_client;
}

std::shared_ptr<client_lease> client_quota::acquire(const std::string& client) {
  std::lock_guard lock(state_->mutex);
  const auto found = state_->held.find(client);
  const std::size_t held = found == state_->held.end() ? 0 : found->second;
  if (held >= state_->max_per_client) return nullptr;
  ++state_->held[client];
  return std::shared_ptr<client_lease>(new client_lease(state_, client));
}

std::size_t client_quota::held(const std::string& client) const {
  std::lock_guard lock(state_->mutex);
  const auto found = state_->held.find(client);
  return found == state_->held.end() ? 0 : found->second;
}

client_lease::client_lease(std::shared_ptr<client_quota::state> owner, std::string client)
    : owner_(std::move(owner)), client_(std::move(client)) {}

client_lease::~client_lease() {
  std::lock_guard lock(owner_->mutex);
  const auto found = owner_->held.find(client_);
  if (found != owner_->held.end() && --found->second == 0) owner_->held.erase(found);
}

}  // namespace tracemesh::server
