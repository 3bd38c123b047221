#pragma once
/// @file mesh_encoders.hpp
/// surface_mesh → bytes, in the formats of mesh_format.hpp (plus MSMS .vert/.face for BEM solvers).
/// Every encoder is a pure function of the mesh: the same mesh gives the same bytes (no timestamps, no locale,
/// no thread-count dependence), so encoded meshes can be cached and compared byte for byte.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh.hpp"
#include "core/status.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::proto {

/// A mesh as a reader of the bytes gets it, checked the way that matters for delivery: what quantisation or
/// float32 rounding can break in a certified mesh. All zero (passed()) for a certified mesh delivered faithfully.
struct delivered_check {
  std::size_t coincident_vertices = 0;   ///< vertices at exactly the same position as an earlier one
  std::size_t degenerate_triangles = 0;  ///< zero area or an edge < 1e-9 Å (mesh_analysis's rule)
  std::size_t boundary_edges = 0;
  std::size_t non_manifold_edges = 0;
  std::size_t non_manifold_vertices = 0;
  std::size_t inconsistently_oriented_edges = 0;
  std::size_t self_intersections = 0;
  bool passed() const noexcept {
    return coincident_vertices == 0 && degenerate_triangles == 0 && boundary_edges == 0 && non_manifold_edges == 0 &&
           non_manifold_vertices == 0 && inconsistently_oriented_edges == 0 && self_intersections == 0;
  }
};

/// Checks `decoded` (see delivered_check): exact coincidence of positions, then mesh_analysis (topology,
/// degeneracy and self-intersections). O(n log n); about as costly as the certificate's analysis.
delivered_check check_delivered_mesh(const surface_mesh& decoded);

/// Draco settings used by encode_draco; fixed so that the bytes for a mesh never change behind a cache key.
struct draco_settings {
  /// Largest quantisation grid step, Å (the issue-12 rule: ≤ 0.01 Å), before any raise.
  static constexpr double max_quantization_step = 0.01;
  /// Largest distance, Å, between a decoded vertex and its double-precision position (Euclidean, so each
  /// coordinate is within max_position_error/√3). Includes float32 rounding.
  static constexpr double max_position_error = 0.01;
  static constexpr int min_position_bits = 11;
  static constexpr int max_position_bits = 30;  ///< Draco's own upper limit
  /// Most bits added to the bounding-box grid when the decoded mesh fails its check (each halves the step; the
  /// ladder needs at most 1): a mesh still broken at step/16 is refused rather than searched further.
  static constexpr int max_bits_raised = 4;
  static constexpr int normal_bits = 10;        ///< octahedral normal quantisation (≈ 0.2° error)
  /// Draco speed 6 (encode and decode): edgebreaker connectivity + parallelogram position prediction. Same size
  /// as speed 5 at ~1.5× the encode speed; speed 0 is ~35 % smaller but 3× slower (see debian-cmake-notes).
  static constexpr int encoding_speed = 6;
  static constexpr int decoding_speed = 6;
  /// Unique ids of the per-vertex atom index and component (GENERIC, int32, 1 component each); their attribute
  /// metadata hold "name" = "atom_index" and "name" = "component". POSITION and NORMAL keep ids 0 and 1.
  static constexpr std::uint32_t atom_index_unique_id = 2;
  static constexpr std::uint32_t component_unique_id = 3;
};

/// Explicit position quantisation grid for a mesh: origin (min corner, float32 as Draco stores it), range (the
/// largest bounding-box side plus a small margin, Å) and bits = ceil(log2(range / step + 1)) clamped to
/// [min_position_bits, max_position_bits], where step is max_quantization_step or less: the largest grid spacing
/// that keeps draco_settings::max_position_error once float32 rounding at the mesh's largest |coordinate| is paid.
struct position_quantization {
  float origin[3] = {0, 0, 0};
  float range = 0;
  int bits = 0;
  /// The grid spacing, Å: range / (2^bits − 1).
  double step() const noexcept;
};

/// The grid from the bounding box alone (encode_draco may raise its bits). errc::invalid_argument for an empty
/// mesh or non-finite coordinates; errc::limit_exceeded when coordinates are so large (beyond ≈ ±30,000 Å) that
/// float32 alone cannot hold the error bound, or the extent needs more than max_position_bits.
result<position_quantization> choose_position_quantization(const surface_mesh& mesh);

/// A Draco encoding with what was checked about it.
struct draco_encoding {
  std::string bytes;
  position_quantization grid;  ///< the grid used, after raises
  int bits_raised = 0;         ///< bits added to the bounding-box rule because the decoded mesh failed its check
  delivered_check decoded;     ///< the check of the decoded bytes (passed)
  float decoded_min[3] = {0, 0, 0};  ///< bounds of the decoded positions (glTF accessor min/max)
  float decoded_max[3] = {0, 0, 0};
};

/// What the encoders read: the mesh, plus what is derived from it once and shared between formats (made on first
/// use: the input is not thread-safe). Keeps a reference to `mesh`, which must outlive it.
class encoder_input {
 public:
  explicit encoder_input(const surface_mesh& mesh) : mesh_(mesh) {}
  const surface_mesh& mesh() const noexcept { return mesh_; }
  /// Per vertex, its connected component: the index into the report's `components` (largest area first), from
  /// mesh_analysis; −1 for a vertex no triangle uses.
  const std::vector<std::int32_t>& components() const;
  /// encode_checked_draco's result, shared by draco and glb.
  const result<draco_encoding>& draco() const;
  /// The mesh with float32 coordinates (what glb-raw and ply carry, with the mesh's own triangles, so topology
  /// cannot change): its coincident vertices and degenerate triangles. Shared by both formats.
  const delivered_check& float32_check() const;

 private:
  const surface_mesh& mesh_;
  mutable std::optional<std::vector<std::int32_t>> components_;
  mutable std::optional<result<draco_encoding>> draco_;
  mutable std::optional<delivered_check> float32_check_;
};

/// Draco 1.5.5 bitstream of the mesh: POSITION (float32, explicit quantisation), NORMAL (float32,
/// draco_settings::normal_bits; present when mesh.normals has one normal per vertex), the atom index (present when
/// mesh.atom_index has one entry per vertex) and the component (see draco_settings for their ids).
/// The grid starts from choose_position_quantization; the bytes are then decoded with Draco's decoder and checked
/// (check_delivered_mesh); while the check fails (quantisation made coincident vertices, zero-area triangles or a
/// self-intersection) the grid gets one more bit, up to max_bits_raised more (and max_position_bits). Edgebreaker reorders vertices and triangles: carry per-vertex
/// data through the attributes, not the order. Decodable by Debian's draco_decoder. Deterministic.
/// Errors: invalid_argument (no triangle, an index ≥ vertex count, normals/atom_index of the wrong size,
/// non-finite coordinates), limit_exceeded (see choose_position_quantization, over 2³¹ vertices, or no grid
/// passes the check), internal_error (Draco refused the mesh; the message carries Draco's).
result<draco_encoding> encode_checked_draco(const encoder_input& input);

/// The mesh Draco bytes decode to (positions, normals, atom_index and, when `components` is given, the component
/// attribute), in the decoder's order. errc::invalid_argument when the bytes are not a Draco triangle mesh.
result<surface_mesh> decode_draco(std::string_view bytes, std::vector<std::int32_t>* components = nullptr);

// ---- the encoders of the format table (mesh_format.hpp) --------------------------------------------------------

/// ASCII OFF: "OFF\n<vertices> <triangles> 0\n", one "x y z" line per vertex (Å, '.' decimal point whatever the
/// locale; 9 significant digits, more when coordinates exceed 1000 Å so that the resolution stays 1e-6 Å), then
/// one "3 a b c" line per triangle with 0-based vertex indices in the mesh's counter-clockwise-from-outside order.
/// Normals, atom indices and components are not part of OFF and are dropped. Never fails for a finite mesh.
result<std::string> encode_off(const encoder_input& input);

/// The bytes of encode_checked_draco.
result<std::string> encode_draco(const encoder_input& input);

/// glTF 2.0 binary (GLB), one scene, one node, one mesh of one triangle primitive compressed with
/// KHR_draco_mesh_compression (required): its buffer view is encode_checked_draco's bytes, and the attributes
/// POSITION (float VEC3, min/max of the decoded positions), NORMAL, _ATOM_INDEX and _COMPONENT (float SCALAR: glTF
/// forbids unsigned int for custom attributes; exact below 2²⁴) map to the Draco ids of draco_settings. 1 unit = 1 Å.
/// Errors: encode_checked_draco's; internal_error if the glTF writer fails.
result<std::string> encode_glb(const encoder_input& input);

/// glTF 2.0 binary without compression: POSITION and NORMAL (float VEC3), _ATOM_INDEX and _COMPONENT (float SCALAR),
/// uint32 indices, in the mesh's vertex and triangle order. Errors: invalid_argument (malformed mesh),
/// limit_exceeded when float32 coordinates break the mesh (float32_check fails: coordinates far from the origin).
result<std::string> encode_glb_raw(const encoder_input& input);

/// PLY 1.0, binary little-endian: element vertex (float x y z nx ny nz, uint atom_index, int component), element
/// face (list uchar uint vertex_indices), in the mesh's order; normals 0 and atom_index 0 when absent. Errors as
/// encode_glb_raw.
result<std::string> encode_ply(const encoder_input& input);

/// format_info(format).encode on a fresh encoder_input.
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
