#pragma once
/// @file tbb_under_thread_sanitizer.hpp
/// For ThreadSanitizer builds (make test-tsan) only. Debian's libtbb is not instrumented, so ThreadSanitizer cannot
/// see the synchronisation inside TBB's scheduler and reports every task handed to another thread as a race. Each
/// program's main() (tracemeshd, tracemesh, the test executables) holds one tbb_under_thread_sanitizer: in such a
/// build it keeps every TBB loop on its calling thread, so that the threads the build checks are the programs' own
/// (the server's I/O, preparation and job workers; the tests'); in any other build it does nothing.

#include <tbb/global_control.h>

#if defined(__SANITIZE_THREAD__)
#define TRACEMESH_THREAD_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define TRACEMESH_THREAD_SANITIZER 1
#endif
#endif

namespace tracemesh {

class tbb_under_thread_sanitizer {
 public:
#ifdef TRACEMESH_THREAD_SANITIZER
  tbb_under_thread_sanitizer() : serial_(tbb::global_control::max_allowed_parallelism, 1) {}

 private:
  tbb::global_control serial_;
#else
  tbb_under_thread_sanitizer() {}  // user-provided: a const instance needs no initialiser and is not "unused"
#endif
};

}  // namespace tracemesh
