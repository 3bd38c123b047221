// Fuzz target of the PQR reader: bytes → (gunzip) → atoms or a status, never a crash.
// Checks the reader's contract on every input:
// - a parsed molecule is non-empty, within the limits, finite, with radii in [0, max_radius] (no -0.0), and
//   zero_radius_atoms counts the zero radii and leaves at least one atom to mesh;
// - an error has an expected code and a one-line printable message of bounded length;
// - rewriting every LF as CRLF changes nothing but line numbers (same code, bitwise the same atoms).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/io/pqr_reader.hpp"
#include "reader_invariants.hpp"

namespace {

using namespace tracemesh;

constexpr std::size_t max_gunzip_bytes = 1 << 20;
/// Fixed text plus at most 40 quoted bytes escaped to 4 characters each stays well under this.
constexpr std::size_t max_message_bytes = 400;

[[noreturn]] void fail(const char* what, const std::string& detail = {}) {
  std::fprintf(stderr, "pqr_reader_fuzzer: invariant violated: %s %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const status& error) {
  const std::string& message = error.message();
  if (message.empty()) fail("empty error message");
  if (message.size() > max_message_bytes) fail("error message too long", message.substr(0, 100));
  for (const char c : message) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) {
      fail("non-printable byte in error message", message.substr(0, 100));
    }
  }
}

void check_parse_error(const status& error) {
  check_message(error);
  const bool line_error = error.code() == errc::invalid_input || error.code() == errc::limit_exceeded;
  if (line_error && error.message().rfind("line ", 0) != 0) fail("message does not name the line", error.message());
  if (error.code() == errc::nothing_to_mesh && error.message().rfind("no atoms with radius > 0", 0) != 0) {
    fail("unexpected nothing_to_mesh message", error.message());
  }
  if (!line_error && error.code() != errc::nothing_to_mesh) fail("unexpected error code", error.message());
}

void check_molecule(const molecule& mol, const mesh_limits& limits) {
  if (mol.atoms.empty()) fail("ok with no atoms");
  if (mol.atoms.size() > limits.max_atoms) fail("more atoms than max_atoms");
  std::size_t zero_radii = 0;
  for (const atom& a : mol.atoms) {
    for (const double coordinate : {a.center.x, a.center.y, a.center.z}) {
      if (!std::isfinite(coordinate) || std::fabs(coordinate) > limits.max_abs_coordinate) {
        fail("coordinate out of range");
      }
    }
    if (!std::isfinite(a.charge)) fail("charge not finite");
    if (!(a.radius >= 0 && a.radius <= limits.max_radius) || std::signbit(a.radius)) fail("radius out of range");
    if (a.radius == 0) ++zero_radii;
  }
  if (zero_radii != mol.zero_radius_atoms) fail("zero_radius_atoms miscounted");
  if (zero_radii == mol.atoms.size()) fail("ok although every radius is 0");
}

/// Appends whole lines rather than bytes: the byte loop was a tenth of the target's time under the sanitizers.
std::string with_crlf_line_endings(std::string_view text) {
  std::string out;
  out.reserve(text.size() + text.size() / 8);
  for (std::size_t begin = 0; begin < text.size();) {
    const std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) {
      out.append(text.substr(begin));
      break;
    }
    out.append(text.substr(begin, end - begin)).append("\r\n");
    begin = end + 1;
  }
  return out;
}

bool same_atoms(const molecule& a, const molecule& b) {
  if (a.atoms.size() != b.atoms.size() || a.zero_radius_atoms != b.zero_radius_atoms) return false;
  for (std::size_t i = 0; i < a.atoms.size(); ++i) {
    if (!(a.atoms[i].center == b.atoms[i].center) || a.atoms[i].radius != b.atoms[i].radius ||
        a.atoms[i].charge != b.atoms[i].charge) {
      return false;
    }
  }
  return true;
}

void check_parse(std::string_view text) {
  const mesh_limits limits = fuzz::small_limits();
  const result<molecule> parsed = parse_pqr(text, limits);
  if (parsed.ok()) {
    check_molecule(*parsed, limits);
  } else {
    check_parse_error(parsed.error());
  }

  const result<molecule> crlf = parse_pqr(with_crlf_line_endings(text), limits);
  if (crlf.ok() != parsed.ok()) fail("CRLF line endings change success");
  if (parsed.ok() && !same_atoms(*parsed, *crlf)) fail("CRLF line endings change the atoms");
  if (!parsed.ok() && crlf.error().code() != parsed.error().code()) {
    fail("CRLF line endings change the error", parsed.error().message() + " | " + crlf.error().message());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const result<std::string> text = maybe_gunzip(input, max_gunzip_bytes);
  if (!text.ok()) {
    check_message(text.error());
    if (text.error().code() != errc::invalid_input && text.error().code() != errc::limit_exceeded) {
      fail("unexpected gunzip error code", text.error().message());
    }
    return 0;
  }
  if (text->size() > max_gunzip_bytes) fail("gunzip output over max_bytes");
  const bool gzip = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  if (!gzip && *text != input) fail("plain input not returned unchanged");
  check_parse(*text);
  return 0;
}
