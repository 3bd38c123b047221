#pragma once
/// @file remesh_mesh.hpp
/// The editable mesh of the remesher: a corner table (half-edge structure stored as flat index arrays, no
/// pointers) of a closed, oriented 2-manifold triangle mesh, with split, collapse and flip that keep it one.
///
/// Half-edge h = 3·f + i of face f runs from the face's corner i to corner (i + 1) mod 3; faces are counter-
/// clockwise seen from outside. Removed faces and vertices stay in the arrays (flagged) until compact().
/// Callers check an edit's preconditions (link condition, valences, see each edit); the edits do not.
///
/// A patch (a piece of a closed mesh, see remesh_chunks.hpp) may be built with boundary edges: their half-edges
/// have no opposite, and their vertices are frozen (remesh.hpp): no edit ever touches them, so their fans never
/// change. Navigation handles their open fans; edits must never be asked to touch them.

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/status.hpp"
#include "core/vec3.hpp"

namespace tracemesh::detail {

inline constexpr std::uint32_t no_index = std::numeric_limits<std::uint32_t>::max();

using triangle_list = std::vector<std::array<std::uint32_t, 3>>;

/// errc::invalid_argument: "remesh: input mesh <why>".
status invalid_mesh(const std::string& why);

/// The checks of every input mesh before its adjacency: one normal per vertex, few enough vertices and triangles
/// for 32-bit indices, every index in range, no face repeating a vertex.
status check_mesh_arrays(std::size_t vertex_count, std::size_t normal_count, const triangle_list& triangles);

/// What the remesher may change around a vertex (see remesh.hpp: frozen regions keep the input mesh).
enum class vertex_protection : std::uint8_t {
  free,    ///< may move, disappear, gain or lose edges
  locked,  ///< next to a frozen vertex: may gain or lose edges, but neither move nor disappear
  frozen,  ///< untouchable: no operation moves it or creates or removes an edge at it
};

class remesh_mesh {
 public:
  /// Builds the corner table of `triangles` over `positions`; `normals` (one per vertex) travel with the vertices.
  /// errc::invalid_argument when an index is out of range, a face repeats a vertex, a vertex is unreferenced, or
  /// the mesh is not closed, edge- and vertex-manifold and consistently oriented.
  /// With `allow_boundary`, boundary edges are accepted (each boundary vertex on one fan) and their vertices are
  /// made frozen. Every vertex's origin() is its index here.
  static result<remesh_mesh> build(std::vector<vec3> positions, std::vector<vec3> normals,
                                   const triangle_list& triangles, bool allow_boundary = false);

  // --- sizes (including removed slots) ---------------------------------------------------------------------
  std::uint32_t vertex_slots() const { return static_cast<std::uint32_t>(position_.size()); }
  std::uint32_t face_slots() const { return static_cast<std::uint32_t>(face_removed_.size()); }
  std::uint32_t halfedge_slots() const { return static_cast<std::uint32_t>(corner_.size()); }
  std::size_t live_face_count() const { return live_faces_; }
  std::size_t live_vertex_count() const { return live_vertices_; }

  // --- navigation -------------------------------------------------------------------------------------------
  static std::uint32_t face_of(std::uint32_t h) { return h / 3; }
  static std::uint32_t next(std::uint32_t h) { return h % 3 == 2 ? h - 2 : h + 1; }
  static std::uint32_t prev(std::uint32_t h) { return h % 3 == 0 ? h + 2 : h - 1; }
  std::uint32_t from(std::uint32_t h) const { return corner_[h]; }
  std::uint32_t to(std::uint32_t h) const { return corner_[next(h)]; }
  /// The vertex of h's face that is not on h.
  std::uint32_t apex(std::uint32_t h) const { return corner_[prev(h)]; }
  std::uint32_t opposite(std::uint32_t h) const { return opposite_[h]; }
  /// One half-edge leaving v; for a boundary vertex, the first of its open fan (the one without an opposite).
  std::uint32_t outgoing(std::uint32_t v) const { return outgoing_[v]; }
  /// The next half-edge leaving from(h), turning around from(h) (visits every face of its fan once); no_index past
  /// the last face of an open fan.
  std::uint32_t rotate(std::uint32_t h) const { return opposite_[prev(h)]; }
  /// Whether v lies on a boundary edge (only in patches; such vertices are frozen).
  bool on_boundary(std::uint32_t v) const { return opposite_[outgoing_[v]] == no_index; }

  bool face_removed(std::uint32_t f) const { return face_removed_[f] != 0; }
  bool vertex_removed(std::uint32_t v) const { return vertex_removed_[v] != 0; }
  std::array<std::uint32_t, 3> face(std::uint32_t f) const {
    return {corner_[3 * f], corner_[3 * f + 1], corner_[3 * f + 2]};
  }

  /// Neighbours of v.
  std::size_t valence(std::uint32_t v) const;
  /// Faces around v.
  std::size_t fan_faces(std::uint32_t v) const;
  /// The neighbours of v in fan order (appends to a cleared `out`).
  void one_ring(std::uint32_t v, std::vector<std::uint32_t>& out) const;
  /// The half-edge from a to b, or no_index when there is none (a and b not adjacent, or b→a a boundary edge).
  std::uint32_t find_halfedge(std::uint32_t a, std::uint32_t b) const;

  // --- per-vertex attributes ----------------------------------------------------------------------------------
  const vec3& position(std::uint32_t v) const { return position_[v]; }
  const vec3& normal(std::uint32_t v) const { return normal_[v]; }
  void move_vertex(std::uint32_t v, const vec3& position, const vec3& normal) {
    position_[v] = position;
    normal_[v] = normal;
    placed_[v] = 1;
  }
  /// True for vertices created or moved by an edit (false for input vertices never touched).
  bool placed(std::uint32_t v) const { return placed_[v] != 0; }
  /// New vertices are free.
  vertex_protection protection(std::uint32_t v) const { return protection_[v]; }
  void set_protection(std::uint32_t v, vertex_protection p) { protection_[v] = p; }
  /// The index v had when the mesh was built, or no_index for a vertex an edit created (kept through compact()).
  std::uint32_t origin(std::uint32_t v) const { return origin_[v]; }

  // --- edits --------------------------------------------------------------------------------------------------
  /// Splits the edge of h with a new vertex (returned) at `position`; the two faces of the edge become four.
  /// Precondition: the apexes of h and opposite(h) differ.
  std::uint32_t split_edge(std::uint32_t h, const vec3& position, const vec3& normal);
  /// Merges to(h) into from(h), which moves to `position`; the two faces of the edge disappear.
  /// Precondition: the link condition holds and the result keeps every valence ≥ 3.
  void collapse_edge(std::uint32_t h, const vec3& position, const vec3& normal);
  /// Replaces the edge of h by the edge joining the two apexes. Precondition: the apexes differ and are not
  /// already adjacent, and both end points of h have valence > 3.
  void flip_edge(std::uint32_t h);

  /// Drops removed faces and vertices, keeping the order of the rest.
  void compact();

  /// The live vertices' positions and normals and the live faces (call compact() first for dense indices).
  const std::vector<vec3>& positions() const { return position_; }
  const std::vector<vec3>& normals() const { return normal_; }
  triangle_list triangles() const;

 private:
  remesh_mesh() = default;
  std::uint32_t add_face();
  std::uint32_t add_vertex(const vec3& position, const vec3& normal);
  void set_face(std::uint32_t f, std::uint32_t a, std::uint32_t b, std::uint32_t c);
  void link(std::uint32_t h, std::uint32_t g) {
    opposite_[h] = g;
    opposite_[g] = h;
  }

  std::vector<vec3> position_;
  std::vector<vec3> normal_;
  std::vector<std::uint32_t> outgoing_;
  std::vector<vertex_protection> protection_;
  std::vector<std::uint8_t> placed_;
  std::vector<std::uint32_t> origin_;
  std::vector<std::uint8_t> vertex_removed_;
  std::vector<std::uint32_t> corner_;    ///< vertex at each corner (= from() of the half-edge with that index)
  std::vector<std::uint32_t> opposite_;  ///< twin half-edge
  std::vector<std::uint8_t> face_removed_;
  std::size_t live_faces_ = 0;
  std::size_t live_vertices_ = 0;
};

}  // namespace tracemesh::detail
