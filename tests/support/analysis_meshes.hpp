#pragma once
// Synthetic meshes with known geometry and topology, shared by tests/core/mesh_analysis_test.cpp and the CGAL
// cross-check (tests/cgal/). Every builder returns counter-clockwise-from-outside triangles unless it says otherwise.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/mesh.hpp"

namespace tracemesh::testing {

using triangle_indices = std::array<std::uint32_t, 3>;

inline surface_mesh icosahedron(double radius = 1.0, const vec3& center = {}) {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  const std::vector<vec3> corners = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
                                     {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
                                     {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  surface_mesh mesh;
  for (const vec3& corner : corners) mesh.positions.push_back(center + radius * normalized(corner));
  mesh.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                    {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                    {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  return mesh;
}

/// Splits every triangle into four and pushes the new vertices onto the sphere (center, radius). Midpoints are
/// shared through a sorted edge list (no maps), so the mesh stays closed.
inline void subdivide_on_sphere(surface_mesh& mesh, double radius, const vec3& center) {
  std::vector<std::array<std::uint32_t, 2>> edges;
  for (const triangle_indices& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) edges.push_back({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const auto first_new = static_cast<std::uint32_t>(mesh.positions.size());
  for (const auto& edge : edges) {
    const vec3 middle = 0.5 * (mesh.positions[edge[0]] + mesh.positions[edge[1]]);
    mesh.positions.push_back(center + radius * normalized(middle - center));
  }
  const auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
    const std::array<std::uint32_t, 2> key{std::min(a, b), std::max(a, b)};
    return first_new + static_cast<std::uint32_t>(std::lower_bound(edges.begin(), edges.end(), key) - edges.begin());
  };
  std::vector<triangle_indices> finer;
  finer.reserve(4 * mesh.triangles.size());
  for (const triangle_indices& t : mesh.triangles) {
    const std::uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
    finer.push_back({t[0], ab, ca});
    finer.push_back({t[1], bc, ab});
    finer.push_back({t[2], ca, bc});
    finer.push_back({ab, bc, ca});
  }
  mesh.triangles = std::move(finer);
}

/// 20·4^levels triangles inscribed in the sphere.
inline surface_mesh icosphere(int levels, double radius = 1.0, const vec3& center = {}) {
  surface_mesh mesh = icosahedron(radius, center);
  for (int level = 0; level < levels; ++level) subdivide_on_sphere(mesh, radius, center);
  return mesh;
}

/// Torus around the z axis: tube radius `minor` at distance `major`; 2·rings·sides triangles.
inline surface_mesh torus(double major, double minor, std::uint32_t rings, std::uint32_t sides) {
  surface_mesh mesh;
  for (std::uint32_t i = 0; i < rings; ++i) {
    const double u = 2 * std::numbers::pi * i / rings;
    for (std::uint32_t j = 0; j < sides; ++j) {
      const double v = 2 * std::numbers::pi * j / sides;
      const double r = major + minor * std::cos(v);
      mesh.positions.push_back({r * std::cos(u), r * std::sin(u), minor * std::sin(v)});
    }
  }
  const auto at = [&](std::uint32_t i, std::uint32_t j) { return (i % rings) * sides + (j % sides); };
  for (std::uint32_t i = 0; i < rings; ++i) {
    for (std::uint32_t j = 0; j < sides; ++j) {
      mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return mesh;
}

/// Tetrahedron a, b, c, d (any non-coplanar corners) with its faces oriented outward; vertex indices 0–3 in order.
inline surface_mesh tetrahedron(const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
  surface_mesh mesh;
  mesh.positions = {a, b, c, d};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  // Orient outward: the first face must see d on its negative side.
  const vec3 normal = cross(c - a, b - a);
  if (dot(normal, d - a) > 0) {
    for (triangle_indices& t : mesh.triangles) std::swap(t[1], t[2]);
  }
  return mesh;
}

/// Appends `part` to `mesh` (its indices shifted).
inline void append(surface_mesh& mesh, const surface_mesh& part) {
  const auto offset = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), part.positions.begin(), part.positions.end());
  mesh.normals.insert(mesh.normals.end(), part.normals.begin(), part.normals.end());
  for (const triangle_indices& t : part.triangles) {
    mesh.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
}

inline void reverse_orientation(surface_mesh& mesh) {
  for (triangle_indices& t : mesh.triangles) std::swap(t[1], t[2]);
}

/// Unit normals pointing away from `center` (outward for a sphere around it).
inline void set_radial_normals(surface_mesh& mesh, const vec3& center, double sign = 1.0) {
  mesh.normals.clear();
  for (const vec3& p : mesh.positions) mesh.normals.push_back(sign * normalized(p - center));
}

/// A flat nx × ny grid of unit squares in the plane z = 0, two triangles each, normals towards +z: a disk.
inline surface_mesh flat_grid(std::uint32_t nx, std::uint32_t ny) {
  surface_mesh mesh;
  for (std::uint32_t i = 0; i <= nx; ++i) {
    for (std::uint32_t j = 0; j <= ny; ++j) mesh.positions.push_back({double(i), double(j), 0.0});
  }
  const auto at = [&](std::uint32_t i, std::uint32_t j) { return i * (ny + 1) + j; };
  for (std::uint32_t i = 0; i < nx; ++i) {
    for (std::uint32_t j = 0; j < ny; ++j) {
      mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return mesh;
}

inline void translate(surface_mesh& mesh, const vec3& offset) {
  for (vec3& p : mesh.positions) p += offset;
}

}  // namespace tracemesh::testing
