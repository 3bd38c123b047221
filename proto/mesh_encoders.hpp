#pragma once
/// @file mesh_encoders.hpp
/// surface_mesh → bytes, in the formats of mesh_format.hpp (plus MSMS .vert/.face for BEM solvers).
/// Every encoder is a pure function of the mesh: the same mesh gives the same bytes (no timestamps, no locale,
/// no thread-count dependence), so encoded meshes can be cached and compared byte for byte.

#include <cstdint>
#include <string>

#include "core/mesh.hpp"
#include "core/status.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::proto {

/// ASCII OFF: "OFF\n<vertices> <triangles> 0\n", one "x y z" line per vertex (Å, 9 significant digits, '.'
/// decimal point whatever the locale), then one "3 a b c" line per triangle with 0-based vertex indices in the
/// mesh's counter-clockwise-from-outside order. Normals and atom indices are not part of OFF and are dropped.
std::string encode_off(const surface_mesh& mesh);

/// Draco settings used by encode_draco; fixed so that the bytes for a mesh never change behind a cache key.
struct draco_settings {
  /// Largest distance, Å, between a decoded vertex and its double-precision position (Euclidean, so each
  /// coordinate is within max_position_error/√3). Includes float32 rounding.
  static constexpr double max_position_error = 0.01;
  static constexpr int min_position_bits = 11;
  static constexpr int max_position_bits = 30;  ///< Draco's own upper limit
  static constexpr int normal_bits = 10;        ///< octahedral normal quantisation (≈ 0.2° error)
  /// Draco speed 6 (encode and decode): edgebreaker connectivity + parallelogram position prediction. Same size
  /// as speed 5 at ~1.5× the encode speed; speed 0 is ~35 % smaller but 3× slower (see debian-cmake-notes).
  static constexpr int encoding_speed = 6;
  static constexpr int decoding_speed = 6;
  /// Unique id of the per-vertex atom index (GENERIC, int32, 1 component); its attribute metadata holds
  /// "name" = "atom_index". POSITION and NORMAL keep Draco's default ids 0 and 1.
  static constexpr std::uint32_t atom_index_unique_id = 2;
};

/// Explicit position quantisation grid for a mesh: origin (min corner, float32 as Draco stores it), range (the
/// largest bounding-box side plus a small margin, Å) and bits = ceil(log2(range / step + 1)) clamped to
/// [min_position_bits, max_position_bits], where step is the largest grid spacing that keeps
/// draco_settings::max_position_error once float32 rounding at the mesh's largest |coordinate| is paid for.
struct position_quantization {
  float origin[3] = {0, 0, 0};
  float range = 0;
  int bits = 0;
};

/// The grid encode_draco uses for `mesh`. errc::invalid_argument for an empty mesh or non-finite coordinates;
/// errc::limit_exceeded when coordinates are so large (beyond ≈ ±30,000 Å) that float32 alone cannot hold the
/// error bound, or the extent needs more than max_position_bits.
result<position_quantization> choose_position_quantization(const surface_mesh& mesh);

/// Draco 1.5.5 bitstream of `mesh`: POSITION (float32, explicit quantisation from choose_position_quantization),
/// NORMAL (float32, draco_settings::normal_bits; present when mesh.normals has one normal per vertex) and the
/// atom index (see draco_settings::atom_index_unique_id; present when mesh.atom_index has one entry per vertex).
/// Edgebreaker reorders vertices and triangles: carry per-vertex data through the attributes, not the order.
/// Decodable by Debian's draco_decoder. Deterministic.
/// Errors: invalid_argument (no triangle, an index ≥ vertex count, normals/atom_index of the wrong size,
/// non-finite coordinates), limit_exceeded (see choose_position_quantization, or over 2³¹ vertices),
/// internal_error (Draco refused the mesh; the message carries Draco's).
result<std::string> encode_draco(const surface_mesh& mesh);

/// encode_off or encode_draco.
result<std::string> encode_mesh(const surface_mesh& mesh, mesh_format format);

/// MSMS .vert (the format BEM solvers such as PyGBe, bempp and TABI read): three header lines
/// ("# ..." comments, then "<vertices> <spheres> <density> <probe radius>"), then per vertex
/// "x y z nx ny nz 0 <atom index, 1-based> 2". Normals point outward (0 0 0 when mesh.normals is empty);
/// the sphere count is the largest atom index + 1; the probe radius is 0 (a Gaussian surface has no probe).
std::string encode_msms_vert(const surface_mesh& mesh);

/// MSMS .face: three header lines ("# ..." comments, then "<triangles> <spheres> <density> <probe radius>"),
/// then per triangle "a b c 2 1" with 1-based vertex indices, counter-clockwise seen from outside.
std::string encode_msms_face(const surface_mesh& mesh);

}  // namespace tracemesh::proto
