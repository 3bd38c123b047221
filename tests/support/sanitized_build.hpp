#pragma once
// Whether the suite runs in a sanitizer build (make test-sanitize and make test-tsan set TRACEMESH_SANITIZED). The
// few tests that would take minutes there skip and run in the Release suite: the largest molecules, and jobs that
// another test already runs under the sanitizers (docs/testing.md lists them).
#include <cstdlib>

namespace tracemesh::testing {

inline bool sanitized_build() { return std::getenv("TRACEMESH_SANITIZED") != nullptr; }

}  // namespace tracemesh::testing
