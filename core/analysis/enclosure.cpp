#include "core/analysis/enclosure.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace tracemesh {
namespace {

constexpr std::uint32_t no_component = std::numeric_limits<std::uint32_t>::max();

struct box {
  vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  vec3 hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity()};
  void add(const vec3& p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  bool contains(const box& inner) const {
    return lo.x <= inner.lo.x && lo.y <= inner.lo.y && lo.z <= inner.lo.z && inner.hi.x <= hi.x &&
           inner.hi.y <= hi.y && inner.hi.z <= hi.z;
  }
};

/// Signed solid angle of triangle (a, b, c) seen from the origin (Van Oosterom & Strackee, 1983).
double solid_angle(const vec3& a, const vec3& b, const vec3& c) {
  const double la = norm(a), lb = norm(b), lc = norm(c);
  const double numerator = dot(a, cross(b, c));
  const double denominator = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
  return 2 * std::atan2(numerator, denominator);
}

}  // namespace

double winding_number(const surface_mesh& mesh, const std::vector<std::uint32_t>& triangles, const vec3& point) {
  double total = 0;
  for (const std::uint32_t t : triangles) {
    const auto& [i, j, k] = mesh.triangles[t];
    total += solid_angle(mesh.positions[i] - point, mesh.positions[j] - point, mesh.positions[k] - point);
  }
  return total / (4 * std::numbers::pi);
}

std::vector<bool> enclosed_components(const surface_mesh& mesh, const mesh_report& report) {
  const std::size_t count = report.components.size();
  std::vector<std::vector<std::uint32_t>> triangles(count);
  std::vector<box> boxes(count);
  std::vector<std::uint32_t> representative(count, no_component);  // one vertex of each component
  const std::vector<std::uint32_t>& label = report.vertex_component;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::uint32_t first = mesh.triangles[t][0];
    if (first >= label.size() || label[first] >= count) continue;
    triangles[label[first]].push_back(static_cast<std::uint32_t>(t));
  }
  for (std::size_t v = 0; v < label.size() && v < mesh.positions.size(); ++v) {
    if (label[v] >= count) continue;
    boxes[label[v]].add(mesh.positions[v]);
    if (representative[label[v]] == no_component) representative[label[v]] = static_cast<std::uint32_t>(v);
  }
  std::vector<char> enclosed(count, 0);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t a) {
    if (representative[a] == no_component) return;
    const vec3& point = mesh.positions[representative[a]];
    for (std::size_t b = 0; b < count && !enclosed[a]; ++b) {
      if (b == a || !boxes[b].contains(boxes[a])) continue;
      if (std::abs(winding_number(mesh, triangles[b], point)) > 0.5) enclosed[a] = 1;
    }
  });
  return {enclosed.begin(), enclosed.end()};
}

std::size_t remove_components(surface_mesh& mesh, const std::vector<std::uint32_t>& vertex_component,
                              const std::vector<bool>& drop) {
  const auto dropped = [&](std::uint32_t v) {
    return v < vertex_component.size() && vertex_component[v] < drop.size() && drop[vertex_component[v]];
  };
  const std::size_t before = mesh.triangles.size();
  std::erase_if(mesh.triangles, [&](const std::array<std::uint32_t, 3>& t) { return dropped(t[0]); });
  // Renumber the vertices still used, in their order.
  std::vector<std::uint32_t> new_index(mesh.positions.size(), no_component);
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t v : t) new_index[v] = 0;
  }
  std::uint32_t next = 0;
  for (auto& index : new_index) {
    if (index != no_component) index = next++;
  }
  const auto compact = [&](auto& values) {
    if (values.size() != new_index.size()) return;
    for (std::size_t v = 0; v < new_index.size(); ++v) {
      if (new_index[v] != no_component) values[new_index[v]] = values[v];
    }
    values.resize(next);
  };
  compact(mesh.positions);
  compact(mesh.normals);
  compact(mesh.atom_index);
  for (auto& t : mesh.triangles) {
    for (std::uint32_t& v : t) v = new_index[v];
  }
  return before - mesh.triangles.size();
}

}  // namespace tracemesh
