#include "core/status.hpp"

namespace tracemesh {

const char* errc_name(errc code) noexcept {
  switch (code) {
    case errc::ok: return "ok";
    case errc::invalid_input: return "invalid_input";
    case errc::nothing_to_mesh: return "nothing_to_mesh";
    case errc::invalid_argument: return "invalid_argument";
    case errc::limit_exceeded: return "limit_exceeded";
    case errc::cancelled: return "cancelled";
    case errc::io_error: return "io_error";
    case errc::internal_error: return "internal_error";
    case errc::unresolvable_input: return "unresolvable_input";
  }
  return "unknown";
}

}  // namespace tracemesh
