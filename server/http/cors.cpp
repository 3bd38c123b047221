#include "server/http/cors.hpp"

#include <algorithm>

namespace tracemesh::server {

namespace {

// What a front-end needs to read besides the simple response headers.
constexpr const char* exposed_headers =
    "ETag, X-Cache, X-Job-Id, X-Job-Token, X-Request-Id, Content-Disposition, Retry-After, Location, Content-Range, "
    "Accept-Ranges";
// Authorization (a server run with bearer tokens) and X-Job-Token (DELETE /jobs/{id}) are not CORS-safelisted:
// without them here a browser refuses to send an authenticated request or a cancellation at all.
constexpr const char* allowed_request_headers =
    "Content-Type, Content-Encoding, If-None-Match, If-Match, X-Request-Id, Range, If-Range, Authorization, "
    "X-Job-Token";
constexpr const char* preflight_max_age_seconds = "600";

}  // namespace

cors_policy::cors_policy(std::vector<std::string> allowed_origins) : origins_(std::move(allowed_origins)) {}

bool cors_policy::any_origin() const { return std::find(origins_.begin(), origins_.end(), "*") != origins_.end(); }

bool cors_policy::allowed(std::string_view origin) const {
  return !origin.empty() && std::find(origins_.begin(), origins_.end(), origin) != origins_.end();
}

void cors_policy::add_response_headers(std::string_view origin, header_list& headers) const {
  if (any_origin()) {
    headers.emplace_back("Access-Control-Allow-Origin", "*");
  } else if (allowed(origin)) {
    headers.emplace_back("Access-Control-Allow-Origin", std::string(origin));
    headers.emplace_back("Vary", "Origin");
  } else {
    if (!origins_.empty()) headers.emplace_back("Vary", "Origin");
    return;
  }
  headers.emplace_back("Access-Control-Expose-Headers", exposed_headers);
}

void cors_policy::add_preflight_headers(std::string_view origin, std::string_view allowed_methods,
                                        header_list& headers) const {
  if (!any_origin() && !allowed(origin)) return;
  headers.emplace_back("Access-Control-Allow-Methods", std::string(allowed_methods));
  headers.emplace_back("Access-Control-Allow-Headers", allowed_request_headers);
  headers.emplace_back("Access-Control-Max-Age", preflight_max_age_seconds);
}

}  // namespace tracemesh::server
