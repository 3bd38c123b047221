// Linked into the test executables of the ThreadSanitizer build only (tests/CMakeLists.txt): see
// core/tbb_under_thread_sanitizer.hpp.
#include "core/tbb_under_thread_sanitizer.hpp"

namespace {

const tracemesh::tbb_under_thread_sanitizer serial_tbb;

}  // namespace
