#include "core/remesh/remesh_mesh.hpp"

#include <string>

namespace tracemesh::detail {
namespace {

/// Outgoing half-edges grouped by their start vertex (compressed rows).
struct outgoing_rows {
  std::vector<std::uint32_t> begin;  ///< vertex_count + 1 offsets
  std::vector<std::uint32_t> halfedges;
};

outgoing_rows group_by_start(const std::vector<std::uint32_t>& corner, std::size_t vertex_count) {
  outgoing_rows rows;
  rows.begin.assign(vertex_count + 1, 0);
  for (const std::uint32_t v : corner) ++rows.begin[v + 1];
  for (std::size_t v = 0; v < vertex_count; ++v) rows.begin[v + 1] += rows.begin[v];
  rows.halfedges.resize(corner.size());
  std::vector<std::uint32_t> fill(rows.begin.begin(), rows.begin.end() - 1);
  for (std::uint32_t h = 0; h < corner.size(); ++h) rows.halfedges[fill[corner[h]]++] = h;
  return rows;
}

}  // namespace

status invalid_mesh(const std::string& why) { return {errc::invalid_argument, "remesh: input mesh " + why}; }

status check_mesh_arrays(std::size_t vertex_count, std::size_t normal_count, const triangle_list& triangles) {
  if (normal_count != vertex_count) return invalid_mesh("has one normal per vertex missing");
  if (vertex_count >= no_index || triangles.size() >= no_index / 3) return invalid_mesh("is too large");
  for (const auto& t : triangles) {
    for (const std::uint32_t v : t) {
      if (v >= vertex_count) return invalid_mesh("has a vertex index out of range");
    }
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) return invalid_mesh("has a face repeating a vertex");
  }
  return status::success();
}

result<remesh_mesh> remesh_mesh::build(std::vector<vec3> positions, std::vector<vec3> normals,
                                       const triangle_list& triangles, bool allow_boundary) {
  const std::size_t vertex_count = positions.size();
  if (status s = check_mesh_arrays(vertex_count, normals.size(), triangles); !s) return s;
  remesh_mesh mesh;
  mesh.corner_.reserve(3 * triangles.size());
  for (const auto& t : triangles) mesh.corner_.insert(mesh.corner_.end(), t.begin(), t.end());

  // Twin of a→b is the unique half-edge b→a; a second a→b means a non-manifold edge or flipped orientation.
  const outgoing_rows rows = group_by_start(mesh.corner_, vertex_count);
  mesh.opposite_.assign(mesh.corner_.size(), no_index);
  for (std::uint32_t h = 0; h < mesh.corner_.size(); ++h) {
    const std::uint32_t a = mesh.from(h), b = mesh.to(h);
    int same_direction = 0;
    for (std::uint32_t k = rows.begin[a]; k < rows.begin[a + 1]; ++k) same_direction += mesh.to(rows.halfedges[k]) == b;
    if (same_direction != 1) return invalid_mesh("has a non-manifold or inconsistently oriented edge");
    for (std::uint32_t k = rows.begin[b]; k < rows.begin[b + 1]; ++k) {
      if (mesh.to(rows.halfedges[k]) == a) mesh.opposite_[h] = rows.halfedges[k];
    }
    if (mesh.opposite_[h] == no_index && !allow_boundary) return invalid_mesh("is not closed (boundary edge)");
  }

  // An open fan starts at its half-edge without opposite (nothing rotates onto it); a closed one anywhere.
  mesh.outgoing_.resize(vertex_count);
  std::vector<std::uint8_t> boundary(vertex_count, 0);
  for (std::uint32_t v = 0; v < vertex_count; ++v) {
    const std::uint32_t fan_size = rows.begin[v + 1] - rows.begin[v];
    if (fan_size == 0) return invalid_mesh("has an unreferenced vertex");
    mesh.outgoing_[v] = rows.halfedges[rows.begin[v]];
    int fan_starts = 0;
    for (std::uint32_t k = rows.begin[v]; k < rows.begin[v + 1]; ++k) {
      const std::uint32_t h = rows.halfedges[k];
      if (mesh.opposite_[h] != no_index) continue;
      mesh.outgoing_[v] = h;
      ++fan_starts;
    }
    boundary[v] = fan_starts > 0;
    // A patch may cut a vertex's fan into several open ones; such a vertex is frozen and never navigated around.
    if (fan_starts > 1 && allow_boundary) continue;
    if (fan_starts > 1 || mesh.fan_faces(v) != fan_size) {
      return invalid_mesh("has a non-manifold vertex (its faces form several fans)");
    }
  }
  mesh.position_ = std::move(positions);
  mesh.normal_ = std::move(normals);
  mesh.protection_.assign(vertex_count, vertex_protection::free);
  for (std::uint32_t v = 0; v < vertex_count; ++v) {
    if (boundary[v]) mesh.protection_[v] = vertex_protection::frozen;
  }
  mesh.placed_.assign(vertex_count, 0);
  mesh.origin_.resize(vertex_count);
  for (std::uint32_t v = 0; v < vertex_count; ++v) mesh.origin_[v] = v;
  mesh.vertex_removed_.assign(vertex_count, 0);
  mesh.face_removed_.assign(triangles.size(), 0);
  mesh.live_faces_ = triangles.size();
  mesh.live_vertices_ = vertex_count;
  return mesh;
}

std::size_t remesh_mesh::fan_faces(std::uint32_t v) const {
  std::size_t count = 0;
  const std::uint32_t start = outgoing_[v];
  std::uint32_t h = start;
  do {
    ++count;
    h = rotate(h);
  } while (h != start && h != no_index && count <= corner_.size());
  return count;
}

std::size_t remesh_mesh::valence(std::uint32_t v) const {
  // An open fan of k faces has k + 1 neighbours.
  return fan_faces(v) + (on_boundary(v) ? 1 : 0);
}

void remesh_mesh::one_ring(std::uint32_t v, std::vector<std::uint32_t>& out) const {
  out.clear();
  const std::uint32_t start = outgoing_[v];
  std::uint32_t h = start, last = start;
  do {
    out.push_back(to(h));
    last = h;
    h = rotate(h);
  } while (h != start && h != no_index);
  if (h == no_index) out.push_back(apex(last));  // the far end of an open fan
}

std::uint32_t remesh_mesh::find_halfedge(std::uint32_t a, std::uint32_t b) const {
  const std::uint32_t start = outgoing_[a];
  std::uint32_t h = start;
  do {
    if (to(h) == b) return h;
    h = rotate(h);
  } while (h != start && h != no_index);
  return no_index;
}

std::uint32_t remesh_mesh::add_face() {
  face_removed_.push_back(0);
  corner_.insert(corner_.end(), 3, no_index);
  opposite_.insert(opposite_.end(), 3, no_index);
  ++live_faces_;
  return face_slots() - 1;
}

std::uint32_t remesh_mesh::add_vertex(const vec3& position, const vec3& normal) {
  position_.push_back(position);
  normal_.push_back(normal);
  outgoing_.push_back(no_index);
  protection_.push_back(vertex_protection::free);
  placed_.push_back(1);
  origin_.push_back(no_index);
  vertex_removed_.push_back(0);
  ++live_vertices_;
  return vertex_slots() - 1;
}

void remesh_mesh::set_face(std::uint32_t f, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  corner_[3 * f] = a;
  corner_[3 * f + 1] = b;
  corner_[3 * f + 2] = c;
}

std::uint32_t remesh_mesh::split_edge(std::uint32_t h, const vec3& position, const vec3& normal) {
  // Faces (a, b, c) and (b, a, d) become (a, m, c), (m, b, c), (b, m, d) and (m, a, d).
  const std::uint32_t o = opposite_[h];
  const std::uint32_t a = from(h), b = to(h), c = apex(h), d = apex(o);
  const std::uint32_t twin_bc = opposite_[next(h)], twin_ca = opposite_[prev(h)];
  const std::uint32_t twin_ad = opposite_[next(o)], twin_db = opposite_[prev(o)];
  const std::uint32_t f0 = face_of(h), f1 = face_of(o);
  const std::uint32_t m = add_vertex(position, normal);
  const std::uint32_t f2 = add_face(), f3 = add_face();
  set_face(f0, a, m, c);  // a→m, m→c, c→a
  set_face(f2, m, b, c);  // m→b, b→c, c→m
  set_face(f1, b, m, d);  // b→m, m→d, d→b
  set_face(f3, m, a, d);  // m→a, a→d, d→m
  link(3 * f0, 3 * f3);
  link(3 * f0 + 1, 3 * f2 + 2);
  link(3 * f0 + 2, twin_ca);
  link(3 * f2, 3 * f1);
  link(3 * f2 + 1, twin_bc);
  link(3 * f1 + 1, 3 * f3 + 2);
  link(3 * f1 + 2, twin_db);
  link(3 * f3 + 1, twin_ad);
  outgoing_[a] = 3 * f0;
  outgoing_[b] = 3 * f2 + 1;
  outgoing_[c] = 3 * f0 + 2;
  outgoing_[d] = 3 * f1 + 2;
  outgoing_[m] = 3 * f2;
  return m;
}

void remesh_mesh::collapse_edge(std::uint32_t h, const vec3& position, const vec3& normal) {
  // Faces (a, b, c) and (b, a, d) disappear; b's other faces take a instead of b.
  const std::uint32_t o = opposite_[h];
  const std::uint32_t a = from(h), b = to(h), c = apex(h), d = apex(o);
  const std::uint32_t twin_cb = opposite_[next(h)];  // c→b, becomes c→a
  const std::uint32_t twin_ac = opposite_[prev(h)];  // a→c
  const std::uint32_t twin_da = opposite_[next(o)];  // d→a
  const std::uint32_t twin_bd = opposite_[prev(o)];  // b→d, becomes a→d
  std::uint32_t g = o;
  do {
    corner_[g] = a;
    g = rotate(g);
  } while (g != o);
  link(twin_cb, twin_ac);
  link(twin_da, twin_bd);
  face_removed_[face_of(h)] = 1;
  face_removed_[face_of(o)] = 1;
  vertex_removed_[b] = 1;
  live_faces_ -= 2;
  --live_vertices_;
  if (!(position_[a] == position)) placed_[a] = 1;
  position_[a] = position;
  normal_[a] = normal;
  outgoing_[a] = twin_ac;
  outgoing_[c] = twin_cb;
  outgoing_[d] = twin_da;
}

void remesh_mesh::flip_edge(std::uint32_t h) {
  // Faces (a, b, c) and (b, a, d) become (a, d, c) and (d, b, c).
  const std::uint32_t o = opposite_[h];
  const std::uint32_t a = from(h), b = to(h), c = apex(h), d = apex(o);
  const std::uint32_t twin_bc = opposite_[next(h)], twin_ca = opposite_[prev(h)];
  const std::uint32_t twin_ad = opposite_[next(o)], twin_db = opposite_[prev(o)];
  const std::uint32_t f0 = face_of(h), f1 = face_of(o);
  set_face(f0, a, d, c);  // a→d, d→c, c→a
  set_face(f1, d, b, c);  // d→b, b→c, c→d
  link(3 * f0, twin_ad);
  link(3 * f0 + 1, 3 * f1 + 2);
  link(3 * f0 + 2, twin_ca);
  link(3 * f1, twin_db);
  link(3 * f1 + 1, twin_bc);
  outgoing_[a] = 3 * f0;
  outgoing_[b] = 3 * f1 + 1;
  outgoing_[c] = 3 * f0 + 2;
  outgoing_[d] = 3 * f1;
}

void remesh_mesh::compact() {
  std::vector<std::uint32_t> vertex_map(vertex_slots(), no_index);
  std::uint32_t kept_vertices = 0;
  for (std::uint32_t v = 0; v < vertex_slots(); ++v) {
    if (vertex_removed(v)) continue;
    vertex_map[v] = kept_vertices;
    position_[kept_vertices] = position_[v];
    normal_[kept_vertices] = normal_[v];
    outgoing_[kept_vertices] = outgoing_[v];
    protection_[kept_vertices] = protection_[v];
    placed_[kept_vertices] = placed_[v];
    origin_[kept_vertices] = origin_[v];
    ++kept_vertices;
  }
  std::vector<std::uint32_t> face_map(face_slots(), no_index);
  std::uint32_t kept_faces = 0;
  for (std::uint32_t f = 0; f < face_slots(); ++f) {
    if (!face_removed(f)) face_map[f] = kept_faces++;
  }
  const auto map_halfedge = [&](std::uint32_t h) {
    return h == no_index ? no_index : 3 * face_map[face_of(h)] + h % 3;
  };
  for (std::uint32_t f = 0; f < face_slots(); ++f) {
    if (face_removed(f)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t h = 3 * f + i, mapped = 3 * face_map[f] + i;
      corner_[mapped] = vertex_map[corner_[h]];
      opposite_[mapped] = map_halfedge(opposite_[h]);
    }
  }
  for (std::uint32_t v = 0; v < kept_vertices; ++v) outgoing_[v] = map_halfedge(outgoing_[v]);

  position_.resize(kept_vertices);
  normal_.resize(kept_vertices);
  outgoing_.resize(kept_vertices);
  protection_.resize(kept_vertices);
  placed_.resize(kept_vertices);
  origin_.resize(kept_vertices);
  vertex_removed_.assign(kept_vertices, 0);
  corner_.resize(3 * std::size_t{kept_faces});
  opposite_.resize(3 * std::size_t{kept_faces});
  face_removed_.assign(kept_faces, 0);
  live_faces_ = kept_faces;
  live_vertices_ = kept_vertices;
}

triangle_list remesh_mesh::triangles() const {
  triangle_list out;
  out.reserve(live_faces_);
  for (std::uint32_t f = 0; f < face_slots(); ++f) {
    if (!face_removed(f)) out.push_back(face(f));
  }
  return out;
}

}  // namespace tracemesh::detail
