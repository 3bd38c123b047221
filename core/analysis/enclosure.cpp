#include "core/analysis/enclosure.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

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

namespace {

/// Twice the signed area of (u, v, p) projected on the yz plane.
double orient_yz(const vec3& u, const vec3& v, const vec3& p) {
  return (v.y - u.y) * (p.z - u.z) - (v.z - u.z) * (p.y - u.y);
}

/// Coordinates in which rays run along +x: (dot(p, along), dot(p, across1), dot(p, across2)) for an orthonormal
/// basis. The identity frame (rays along x) gives the coordinates themselves, bit for bit.
struct ray_frame {
  vec3 along{1, 0, 0}, across1{0, 1, 0}, across2{0, 0, 1};
  vec3 operator()(const vec3& p) const { return {dot(p, along), dot(p, across1), dot(p, across2)}; }
};

/// A direction in no lattice plane or line: trace meshes have many vertices on common lines parallel to x (the
/// line roots), so rays along x from them meet other components' vertices exactly.
ray_frame skewed_frame() {
  ray_frame frame;
  frame.along = normalized(vec3{1, 0.3141592653589793, 0.2718281828459045});
  frame.across1 = normalized(cross(frame.along, vec3{0, 0, 1}));
  frame.across2 = cross(frame.along, frame.across1);
  return frame;
}

/// A ray from a point along +x, and what the triangles of one closed component did to it.
struct ray_count {
  int signed_crossings = 0;  ///< +1 per triangle crossed facing +x, −1 facing −x: the winding number
  bool degenerate = false;   ///< the ray met an edge or a vertex, or started on a triangle: count not trusted
};

/// Adds what triangle (a, b, c) does to the ray from p along +x. The ray crosses it where the projection of p on
/// the yz plane lies strictly inside the triangle's, beyond p; a crossing within a relative 1e-10 of an edge, or
/// within 1e-9 Å of p, marks the count degenerate instead.
void cross_ray(const vec3& a, const vec3& b, const vec3& c, const vec3& p, ray_count& count) {
  const double oa = orient_yz(b, c, p), ob = orient_yz(c, a, p), oc = orient_yz(a, b, p);
  const double tolerance = 1e-10 * (std::abs(oa) + std::abs(ob) + std::abs(oc));
  const bool inside = (oa > tolerance && ob > tolerance && oc > tolerance) ||
                      (oa < -tolerance && ob < -tolerance && oc < -tolerance);
  if (!inside) {
    const bool on_edge = (oa >= -tolerance && ob >= -tolerance && oc >= -tolerance) ||
                         (oa <= tolerance && ob <= tolerance && oc <= tolerance);
    // Only an edge ahead of p (or at it) matters; one behind it is never crossed.
    if (on_edge && std::max({a.x, b.x, c.x}) >= p.x - 1e-9) count.degenerate = true;
    return;
  }
  const double area = oa + ob + oc;  // twice the projected area, signed like the face normal's x component
  const double x = (oa * a.x + ob * b.x + oc * c.x) / area;
  if (std::abs(x - p.x) <= 1e-9) {
    count.degenerate = true;
  } else if (x > p.x) {
    count.signed_crossings += area > 0 ? 1 : -1;
  }
}

/// Points bucketed by a grid over their projections on the yz plane, so that one pass over a surface's triangles
/// finds, for each triangle, the few points whose ray along +x may cross it. About one point per cell.
class yz_point_grid {
 public:
  explicit yz_point_grid(const std::vector<vec3>& points) {
    for (const vec3& p : points) bounds_.add(p);
    cells_ = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(std::sqrt(double(points.size())))));
    cell_y_ = std::max(bounds_.hi.y - bounds_.lo.y, 1e-9) / double(cells_);
    cell_z_ = std::max(bounds_.hi.z - bounds_.lo.z, 1e-9) / double(cells_);
    std::vector<std::uint32_t> cell_of(points.size());
    first_.assign(cells_ * cells_ + 1, 0);
    for (std::size_t i = 0; i < points.size(); ++i) {
      cell_of[i] = static_cast<std::uint32_t>(index(points[i].y, bounds_.lo.y, cell_y_) * cells_ +
                                              index(points[i].z, bounds_.lo.z, cell_z_));
      ++first_[cell_of[i] + 1];
    }
    for (std::size_t c = 1; c < first_.size(); ++c) first_[c] += first_[c - 1];
    members_.resize(points.size());
    std::vector<std::uint32_t> next(first_.begin(), first_.end() - 1);
    for (std::size_t i = 0; i < points.size(); ++i) members_[next[cell_of[i]]++] = static_cast<std::uint32_t>(i);
  }

  /// Calls visit(i) for each point i whose projection may lie in the yz extent of box `b` (a superset).
  template <class Visit>
  void for_each_near(const box& b, Visit&& visit) const {
    if (b.hi.y < bounds_.lo.y || b.lo.y > bounds_.hi.y || b.hi.z < bounds_.lo.z || b.lo.z > bounds_.hi.z) return;
    const std::size_t y0 = index(b.lo.y, bounds_.lo.y, cell_y_), y1 = index(b.hi.y, bounds_.lo.y, cell_y_);
    const std::size_t z0 = index(b.lo.z, bounds_.lo.z, cell_z_), z1 = index(b.hi.z, bounds_.lo.z, cell_z_);
    for (std::size_t y = y0; y <= y1; ++y) {
      for (std::size_t z = z0; z <= z1; ++z) {
        const std::size_t c = y * cells_ + z;
        for (std::uint32_t k = first_[c]; k < first_[c + 1]; ++k) visit(members_[k]);
      }
    }
  }

 private:
  std::size_t index(double value, double origin, double size) const {
    const double i = std::floor((value - origin) / size);
    return i <= 0 ? 0 : std::min(cells_ - 1, static_cast<std::size_t>(i));
  }

  box bounds_;
  std::size_t cells_ = 1;
  double cell_y_ = 1, cell_z_ = 1;
  std::vector<std::uint32_t> first_;    // per cell, the index of its first member; one more entry at the end
  std::vector<std::uint32_t> members_;  // point indices, cell by cell
};

/// The rays from `points` along +x against the surface `triangles`, in one pass over the triangles (in parallel;
/// the counts are integer sums, so the result does not depend on the thread count).
std::vector<ray_count> cast_rays(const surface_mesh& mesh, const std::vector<std::uint32_t>& triangles,
                                 const std::vector<vec3>& original_points, const ray_frame& frame) {
  std::vector<vec3> points(original_points.size());
  for (std::size_t k = 0; k < points.size(); ++k) points[k] = frame(original_points[k]);
  const yz_point_grid grid(points);
  tbb::enumerable_thread_specific<std::vector<ray_count>> partial(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<ray_count>& counts = partial.local();
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const auto& [ia, ib, ic] = mesh.triangles[triangles[i]];
                        const vec3 a = frame(mesh.positions[ia]), b = frame(mesh.positions[ib]),
                                   c = frame(mesh.positions[ic]);
                        box bounds;
                        bounds.add(a);
                        bounds.add(b);
                        bounds.add(c);
                        grid.for_each_near(bounds, [&](std::uint32_t k) {
                          const vec3& p = points[k];
                          const bool beside = p.y < bounds.lo.y || p.y > bounds.hi.y || p.z < bounds.lo.z ||
                                              p.z > bounds.hi.z || bounds.hi.x < p.x - 1e-9;
                          if (!beside) cross_ray(a, b, c, p, counts[k]);
                        });
                      }
                    });
  std::vector<ray_count> total(points.size());
  for (const std::vector<ray_count>& counts : partial) {
    for (std::size_t k = 0; k < counts.size(); ++k) {
      total[k].signed_crossings += counts[k].signed_crossings;
      total[k].degenerate = total[k].degenerate || counts[k].degenerate;
    }
  }
  return total;
}

}  // namespace

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
  // The components each component may enclose: those whose box lies in its box.
  std::vector<std::vector<std::uint32_t>> candidates(count);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t b) {
    for (std::size_t a = 0; a < count; ++a) {
      if (a != b && representative[a] != no_component && boxes[b].contains(boxes[a])) {
        candidates[b].push_back(static_cast<std::uint32_t>(a));
      }
    }
  });
  // One pass over each enclosing candidate's triangles casts the rays of all its candidates at once, along x.
  // The rays that met an edge or a vertex are cast again together along a skewed direction; a ray degenerate both
  // ways is decided by the winding number, which has no such case.
  const ray_frame frames[] = {ray_frame{}, skewed_frame()};
  std::vector<char> enclosed(count, 0);
  for (std::size_t b = 0; b < count; ++b) {
    std::vector<std::uint32_t> undecided = candidates[b];
    for (const ray_frame& frame : frames) {
      if (undecided.empty()) break;
      std::vector<vec3> points;
      points.reserve(undecided.size());
      for (const std::uint32_t a : undecided) points.push_back(mesh.positions[representative[a]]);
      const std::vector<ray_count> rays = cast_rays(mesh, triangles[b], points, frame);
      std::vector<std::uint32_t> degenerate;
      for (std::size_t k = 0; k < rays.size(); ++k) {
        if (rays[k].degenerate) {
          degenerate.push_back(undecided[k]);
        } else if (rays[k].signed_crossings != 0) {
          enclosed[undecided[k]] = 1;
        }
      }
      undecided = std::move(degenerate);
    }
    for (const std::uint32_t a : undecided) {
      if (std::abs(winding_number(mesh, triangles[b], mesh.positions[representative[a]])) > 0.5) enclosed[a] = 1;
    }
  }
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
