#pragma once
/// @file nanoshaper_files.hpp
/// The mesh files as NanoShaper writes them, for the clients that read them (TABI-PB, APBS's BEM path, PyGBe and
/// bempp scripts).

#include <string>

#include "core/mesh.hpp"

namespace tracemesh::cli::nanoshaper {

/// NanoShaper's .vert: two comment lines, then the vertex count alone on line 3 (TABI-PB reads that line with one
/// "%d": MSMS's "<count> <spheres> <density> <probe>" would shift every later number), then proto's MSMS vertex
/// lines "x y z nx ny nz 0 <atom, 1-based> 2" (encode_msms_vert), unit outward normals. No blank line.
std::string nanoshaper_vert(const surface_mesh& mesh);

/// NanoShaper's .face: the same header with the triangle count, then proto's MSMS triangle lines "a b c 2 1",
/// 1-based, counter-clockwise seen from outside (encode_msms_face).
std::string nanoshaper_face(const surface_mesh& mesh);

/// NanoShaper's OFF variants: "OFF+N" (normals), "OFF+A" (nearest atom, 0-based) or "OFF+N+A" on line 1,
/// "<vertices> <triangles> 0", one "x y z[ nx ny nz][ atom]" line per vertex (6 decimals, '.' whatever the locale),
/// one "3 a b c" line per triangle, 0-based. (With neither, "OFF" and the same lines; the command writes plain OFF
/// with proto's encode_off, the format table's writer.)
std::string nanoshaper_off(const surface_mesh& mesh, bool normals, bool atoms);

}  // namespace tracemesh::cli::nanoshaper
