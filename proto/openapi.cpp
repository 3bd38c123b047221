#include "proto/openapi.hpp"

namespace tracemesh::proto {
namespace {

// openapi_json.inc is generated from proto/openapi.json at configure time: its bytes as '\x7b','\x0a',... so
// that any content embeds safely (no raw-string delimiter or length limits to worry about).
constexpr char openapi_bytes[] = {
#include "openapi_json.inc"
};

}  // namespace

std::string_view openapi_document() noexcept { return {openapi_bytes, sizeof openapi_bytes}; }

}  // namespace tracemesh::proto
