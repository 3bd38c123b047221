#pragma once
/// @file release_memory.hpp
/// Hands freed heap memory back to the system between stages.

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace tracemesh {

/// Returns the front end's freed memory to the system before the quality pass allocates its own: the million small
/// arrays of a capsid's blocks leave glibc's arenas fragmented (capsid: peak RSS 1.55 → 1.40 GB).
inline void release_freed_memory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace tracemesh
