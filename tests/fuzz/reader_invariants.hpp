#pragma once
// The contract every molecule reader keeps on any input, checked by the fuzz targets of the readers added with
// read_molecule (xyzr, PDB, mmCIF): an error is one printable line of bounded length with an expected code; a
// molecule is non-empty, within the limits, finite, with radii in [0, max_radius] (no -0.0), zero radii counted.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/io/input_format.hpp"
#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh::fuzz {

/// Small limits so that the fuzzer reaches every limit with short inputs.
inline mesh_limits small_limits() {
  mesh_limits limits;
  limits.max_atoms = 64;
  limits.max_abs_coordinate = 1e4;
  limits.max_radius = 5;
  limits.max_line_bytes = 256;
  return limits;
}

[[noreturn]] inline void fail(const char* reader, const char* what, const std::string& detail = {}) {
  std::fprintf(stderr, "%s: invariant violated: %s %s\n", reader, what, detail.c_str());
  std::abort();
}

inline void check_error(const char* reader, const status& error) {
  const std::string& message = error.message();
  if (message.empty()) fail(reader, "empty error message");
  if (message.size() > 400) fail(reader, "error message too long", message.substr(0, 100));
  for (const char c : message) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) {
      fail(reader, "non-printable byte in error message", message.substr(0, 100));
    }
  }
  const errc code = error.code();
  if (code != errc::invalid_input && code != errc::limit_exceeded && code != errc::nothing_to_mesh) {
    fail(reader, "unexpected error code", message);
  }
  if (code == errc::nothing_to_mesh && message.rfind("no atoms with radius > 0", 0) != 0) {
    fail(reader, "unexpected nothing_to_mesh message", message);
  }
}

inline void check_molecule(const char* reader, const molecule& mol, const mesh_limits& limits) {
  if (mol.atoms.empty()) fail(reader, "ok with no atoms");
  if (mol.atoms.size() > limits.max_atoms) fail(reader, "more atoms than max_atoms");
  std::size_t zero_radii = 0;
  for (const atom& a : mol.atoms) {
    for (const double coordinate : {a.center.x, a.center.y, a.center.z}) {
      if (!std::isfinite(coordinate) || std::fabs(coordinate) > limits.max_abs_coordinate) {
        fail(reader, "coordinate out of range");
      }
    }
    if (!(a.radius >= 0 && a.radius <= limits.max_radius) || std::signbit(a.radius)) {
      fail(reader, "radius out of range");
    }
    if (a.radius == 0) ++zero_radii;
  }
  if (zero_radii != mol.zero_radius_atoms) fail(reader, "zero_radius_atoms miscounted");
  if (zero_radii == mol.atoms.size()) fail(reader, "ok although every radius is 0");
}

template <class Parsed>
void check(const char* reader, const Parsed& parsed, const mesh_limits& limits) {
  if (parsed.ok()) {
    check_molecule(reader, *parsed, limits);
  } else {
    check_error(reader, parsed.error());
  }
}

/// Runs `parse(text, options, limits)` of a structure reader (PDB, mmCIF) under every combination of its options
/// that matters (both radii sets, waters, ligands and hydrogens kept or dropped, the deposited coordinates and
/// assembly 1 built from the file's operators) and checks each result.
template <class Parse>
void check_every_structure_option(const char* reader, std::string_view text, Parse parse) {
  const mesh_limits limits = small_limits();
  for (int variant = 0; variant < 4; ++variant) {
    structure_options options;
    options.radii = variant % 2 == 0 ? radii_set::bondi : radii_set::mantina;
    options.keep_waters = variant >= 2;
    options.keep_ligands = variant < 2;
    options.keep_hydrogens = variant != 1;
    check(reader, parse(text, options, limits), limits);
  }
  structure_options assembled;
  assembled.radii = radii_set::mantina;
  assembled.assembly = "1";
  check(reader, parse(text, assembled, limits), limits);
}

}  // namespace tracemesh::fuzz
