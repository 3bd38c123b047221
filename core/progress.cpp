#include "core/progress.hpp"

namespace tracemesh {

const char* stage_name(mesh_stage stage) noexcept {
  switch (stage) {
    case mesh_stage::reading: return "reading";
    case mesh_stage::culling: return "culling";
    case mesh_stage::sampling: return "sampling";
    case mesh_stage::roots: return "roots";
    case mesh_stage::tracing: return "tracing";
    case mesh_stage::triangulating: return "triangulating";
    case mesh_stage::refining: return "refining";
    case mesh_stage::certifying: return "certifying";
    case mesh_stage::encoding: return "encoding";
    case mesh_stage::done: return "done";
  }
  return "unknown";
}

}  // namespace tracemesh
