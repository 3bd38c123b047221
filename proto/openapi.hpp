#pragma once
/// @file openapi.hpp
/// The OpenAPI 3.0.3 description of the tracemesh HTTP service. proto/openapi.json is the single source of
/// truth; the build embeds its bytes verbatim (proto/CMakeLists.txt), so GET /openapi.json serves exactly it.

#include <string_view>

namespace tracemesh::proto {

/// The document as JSON text (UTF-8). Static storage; never fails.
std::string_view openapi_document() noexcept;

}  // namespace tracemesh::proto
