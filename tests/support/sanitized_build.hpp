#pragma once
// Whether the suite runs in a sanitizer build (make test-sanitize, make test-tsan set TRACEMESH_SANITIZED): the
// tests that only repeat, around a slow job, code another test already runs under the sanitizers skip there and
// run in the Release suite.
#include <cstdlib>

namespace tracemesh::testing {

inline bool sanitized_build() { return std::getenv("TRACEMESH_SANITIZED") != nullptr; }

}  // namespace tracemesh::testing
