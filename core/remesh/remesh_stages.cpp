#include "core/remesh/remesh_stages.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "core/remesh/remesh_intersections.hpp"

namespace tracemesh::detail {
namespace {

/// Appends the triangles with a corner in `vertices` (sorted) to `triangles`, keeping it sorted and unique.
void add_triangles_at(const triangle_list& all, const std::vector<std::uint32_t>& vertices,
                      std::vector<std::uint32_t>& triangles) {
  if (vertices.empty()) return;
  for (std::uint32_t t = 0; t < all.size(); ++t) {
    for (const std::uint32_t v : all[t]) {
      if (std::binary_search(vertices.begin(), vertices.end(), v)) {
        triangles.push_back(t);
        break;
      }
    }
  }
  std::sort(triangles.begin(), triangles.end());
  triangles.erase(std::unique(triangles.begin(), triangles.end()), triangles.end());
}

/// Drops what a stage removed; limit_exceeded when the stage left more than `max_triangles` faces.
status compact_within(remesh_mesh& mesh, std::size_t max_triangles) {
  mesh.compact();
  if (mesh.live_face_count() > max_triangles) {
    return status{errc::limit_exceeded, "remesh: more than max_triangles triangles"};
  }
  return status::success();
}

void add_counts(operation_counts& total, const operation_counts& c) {
  total.splits += c.splits;
  total.collapses += c.collapses;
  total.flips += c.flips;
  total.relaxations += c.relaxations;
  total.rejected += c.rejected;
}

}  // namespace

verified_stages::verified_stages(const gaussian_field& field, const remesh_thresholds& thresholds,
                                 std::size_t max_triangles, progress_token& progress, offending_finder finder)
    : field_(field),
      thresholds_(thresholds),
      max_triangles_(max_triangles),
      progress_(progress),
      finder_(std::move(finder)) {
  if (!finder_) finder_ = [](const remesh_mesh&, const surface_mesh& view) { return find_offending_triangles(view); };
}

result<bool> verified_stages::run(remesh_mesh& state, const remesh_stage& stage, bool settle) {
  remesh_operations ops(state, field_, thresholds_, progress_);
  if (!stage(state, ops)) return status{errc::cancelled, "remesh: cancelled"};
  if (status s = compact_within(state, max_triangles_); !s) return s;
  const std::vector<std::uint32_t> unsettled = settle ? ops.settle_vertices() : std::vector<std::uint32_t>{};
  field_evaluations_ += ops.counts().field_evaluations;
  add_counts(counts_, ops.counts());
  if (!settle) return true;
  failure_.mesh = certificate_view(state);
  failure_.offending = finder_(state, failure_.mesh);
  add_triangles_at(failure_.mesh.triangles, unsettled, failure_.offending);
  return failure_.offending.empty();
}

surface_mesh certificate_view(const remesh_mesh& mesh) {
  surface_mesh view;
  view.positions = mesh.positions();
  view.normals = mesh.normals();
  view.triangles = mesh.triangles();
  return view;
}

std::size_t freeze_near(const std::vector<vec3>& points, const std::vector<vec3>& triangle_positions,
                        const triangle_list& triangles, const std::vector<std::uint32_t>& listed, double radius,
                        std::vector<std::uint8_t>& frozen) {
  // The listed triangles' boxes grown by the radius.
  std::vector<box3> regions;
  double largest = radius;
  for (const std::uint32_t t : listed) {
    box3 b = bounds_of(triangle_positions, triangles[t]);
    b.lo -= vec3{radius, radius, radius};
    b.hi += vec3{radius, radius, radius};
    for (int axis = 0; axis < 3; ++axis) largest = std::max(largest, b.hi[axis] - b.lo[axis]);
    regions.push_back(b);
  }
  // Regions hashed into cells at least as large as any region: a point only checks the regions of its own cell.
  using cell_key = std::array<std::int64_t, 3>;
  const auto cell_of = [&](const vec3& p) {
    return cell_key{static_cast<std::int64_t>(std::floor(p.x / largest)),
                    static_cast<std::int64_t>(std::floor(p.y / largest)),
                    static_cast<std::int64_t>(std::floor(p.z / largest))};
  };
  std::vector<std::pair<cell_key, std::uint32_t>> cells;
  for (std::uint32_t r = 0; r < regions.size(); ++r) {
    const cell_key lo = cell_of(regions[r].lo), hi = cell_of(regions[r].hi);
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) cells.push_back({{x, y, z}, r});
      }
    }
  }
  std::sort(cells.begin(), cells.end());
  const auto in_a_region = [&](const vec3& p) {
    const cell_key key = cell_of(p);
    for (auto it = std::lower_bound(cells.begin(), cells.end(), std::pair<cell_key, std::uint32_t>{key, 0});
         it != cells.end() && it->first == key; ++it) {
      if (regions[it->second].contains(p)) return true;
    }
    return false;
  };
  std::vector<std::uint8_t> newly(points.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024), [&](const auto& range) {
    for (std::size_t v = range.begin(); v != range.end(); ++v) newly[v] = !frozen[v] && in_a_region(points[v]);
  });
  std::size_t count = 0;
  for (std::size_t v = 0; v < points.size(); ++v) {
    frozen[v] |= newly[v];
    count += newly[v];
  }
  return count;
}

void protect(remesh_mesh& mesh, const std::vector<std::uint8_t>& frozen) {
  // Through the faces rather than the 1-rings: a frozen patch-boundary vertex may have several open fans.
  for (std::uint32_t v = 0; v < frozen.size(); ++v) {
    if (frozen[v]) mesh.set_protection(v, vertex_protection::frozen);
  }
  for (std::uint32_t f = 0; f < mesh.face_slots(); ++f) {
    if (mesh.face_removed(f)) continue;
    const auto t = mesh.face(f);
    const bool touches_frozen = frozen[t[0]] || frozen[t[1]] || frozen[t[2]];
    if (!touches_frozen) continue;
    for (const std::uint32_t x : t) {
      if (!frozen[x]) mesh.set_protection(x, vertex_protection::locked);
    }
  }
}

std::vector<std::uint8_t> frozen_flags(const remesh_mesh& mesh) {
  std::vector<std::uint8_t> frozen(mesh.vertex_slots());
  for (std::uint32_t v = 0; v < mesh.vertex_slots(); ++v) frozen[v] = mesh.protection(v) == vertex_protection::frozen;
  return frozen;
}

}  // namespace tracemesh::detail
