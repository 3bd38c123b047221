#pragma once
/// @file cors.hpp
/// Cross-origin resource sharing for browser front-ends: which Origins may read responses (--cors-origin,
/// default "*"), the headers they may read, and the answer to OPTIONS preflight requests.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tracemesh::server {

using header_list = std::vector<std::pair<std::string, std::string>>;

class cors_policy {
 public:
  /// `allowed_origins`: exact Origin values ("https://lab.example.org"), or "*" for any origin. Empty → CORS off.
  explicit cors_policy(std::vector<std::string> allowed_origins);

  /// Headers for a response to a request carrying `origin` (empty when the request had no Origin header):
  /// Access-Control-Allow-Origin (+ Vary: Origin when it depends on the request) and Expose-Headers.
  /// Nothing for a disallowed origin (the browser then blocks the read).
  void add_response_headers(std::string_view origin, header_list& headers) const;

  /// Headers answering a preflight (OPTIONS with Access-Control-Request-Method) for a route allowing
  /// `allowed_methods` ("GET, HEAD, DELETE").
  void add_preflight_headers(std::string_view origin, std::string_view allowed_methods, header_list& headers) const;

 private:
  bool any_origin() const;
  bool allowed(std::string_view origin) const;

  std::vector<std::string> origins_;
};

}  // namespace tracemesh::server
