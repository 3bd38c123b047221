#include "core/remesh/remesh_small_components.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_moved_triangles.hpp"
#include "core/analysis/analysis_topology.hpp"
#include "core/remesh/remesh_geometry.hpp"

namespace tracemesh::detail {
namespace {

/// Components whose bounding box's diagonal is at most this × L are made again: larger ones have edges the
/// iterations can work on (the smallest cavities that kept an edge under 0.1 × the median were 1.1–1.7 L across).
constexpr double max_diameter_in_edges = 2.0;
/// ...and that have at most this many vertices (a bound on the hull's brute-force cost, far above what 2 L holds).
constexpr std::size_t max_component_vertices = 40;
/// Rotations of the ray directions tried; the one whose worst triangle is best is kept.
constexpr int direction_rotations = 8;
/// A ray is marched in this many steps of its reach before its first crossing is bracketed.
constexpr int ray_march_steps = 24;
/// The ray's reach, in units of the component's diameter.
constexpr double ray_reach_in_diameters = 2.0;
/// Polishing: tangent directions tried per vertex and move, and the first and last step, in units of the
/// component's diameter.
constexpr int polish_directions = 6;
constexpr double polish_first_step = 0.1;
constexpr double polish_last_step = 0.005;
/// Polishing stops once every triangle is at least this good (equilateral: 1).
constexpr double polish_enough_quality = 0.9;
/// Sweeps over the vertices at one step length, at most (each sweep moves every vertex that can improve).
constexpr int polish_sweeps_per_step = 4;

using triangle = std::array<std::uint32_t, 3>;

struct small_component {
  std::vector<std::uint32_t> vertices;
  std::vector<std::uint32_t> triangles;
  double diameter = 0;  ///< the diagonal of its vertices' bounding box
};

/// A component on its own: its vertices with their field normals, and its triangles (numbered 0 … n − 1).
struct small_mesh {
  std::vector<vec3> positions, normals;
  std::vector<triangle> triangles;
};

/// The closed genus-0 components of `mesh` at most max_diameter_in_edges × L across, in label order.
std::vector<small_component> find_small_components(const surface_mesh& mesh, double target_edge) {
  const component_labels labels =
      label_components(mesh, std::vector<triangle_defect>(mesh.triangles.size(), triangle_defect::none));
  std::vector<std::size_t> vertex_count(labels.count, 0);
  for (const std::uint32_t c : labels.of_vertex) {
    if (c < labels.count) ++vertex_count[c];
  }
  std::vector<small_component> all(labels.count);
  for (std::uint32_t v = 0; v < mesh.positions.size(); ++v) {
    const std::uint32_t c = labels.of_vertex[v];
    if (c < labels.count && vertex_count[c] <= max_component_vertices) all[c].vertices.push_back(v);
  }
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    const std::uint32_t c = labels.of_triangle[f];
    if (c < labels.count && vertex_count[c] <= max_component_vertices) all[c].triangles.push_back(f);
  }
  std::vector<small_component> small;
  for (small_component& c : all) {
    if (c.vertices.empty()) continue;
    // Closed: E = 3F/2, so genus 0 (V − E + F = 2) is 2V − F = 4.
    if (2 * c.vertices.size() != c.triangles.size() + 4) continue;
    box3 box{mesh.positions[c.vertices[0]], mesh.positions[c.vertices[0]]};
    for (const std::uint32_t v : c.vertices) {
      for (int axis = 0; axis < 3; ++axis) {
        box.lo[axis] = std::min(box.lo[axis], mesh.positions[v][axis]);
        box.hi[axis] = std::max(box.hi[axis], mesh.positions[v][axis]);
      }
    }
    c.diameter = distance(box.lo, box.hi);
    if (c.diameter <= max_diameter_in_edges * target_edge) small.push_back(std::move(c));
  }
  return small;
}

/// n unit vectors spread evenly over the sphere (a Fibonacci set).
std::vector<vec3> spread_directions(std::size_t n) {
  const double golden_angle = std::numbers::pi * (3 - std::sqrt(5.0));
  std::vector<vec3> directions;
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1 - 2 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double rho = std::sqrt(1 - z * z);
    const double angle = golden_angle * static_cast<double>(i);
    directions.push_back({rho * std::cos(angle), rho * std::sin(angle), z});
  }
  return directions;
}

/// The convex hull of points on the unit sphere, faces counter-clockwise seen from outside; empty when four of them
/// are (nearly) coplanar on a face, which a Fibonacci set of a few dozen points does not do.
std::vector<triangle> hull_of_directions(const std::vector<vec3>& u) {
  constexpr double coplanar = 1e-9;
  const auto n = static_cast<std::uint32_t>(u.size());
  std::vector<triangle> faces;
  for (std::uint32_t i = 0; i < n; ++i) {
    for (std::uint32_t j = i + 1; j < n; ++j) {
      for (std::uint32_t k = j + 1; k < n; ++k) {
        const vec3 normal = cross(u[j] - u[i], u[k] - u[i]);
        int above = 0, below = 0, on = 0;
        for (std::uint32_t m = 0; m < n; ++m) {
          if (m == i || m == j || m == k) continue;
          const double side = dot(normal, u[m] - u[i]);
          if (side > coplanar) ++above;
          else if (side < -coplanar) ++below;
          else ++on;
        }
        if (on > 0 && (above == 0 || below == 0)) return {};
        if (above == 0) faces.push_back({i, j, k});
        if (below == 0) faces.push_back({i, k, j});
      }
    }
  }
  if (faces.size() != 2 * u.size() - 4) return {};
  return faces;
}

/// The rotation about `axis` (unit) by `angle`, applied to v (Rodrigues).
vec3 rotated(const vec3& v, const vec3& axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c));
}

/// The first point of {φ = t0} on the ray from `centre` along `u` within `reach` Å, with its field normal: marched
/// in ray_march_steps steps until φ − t0 changes sign, then found by Newton's method along the ray, kept inside the
/// bracket (bisection when a step leaves it), to 1e-12 Å.
std::optional<std::pair<vec3, vec3>> first_surface_point(const gaussian_field& field, const vec3& centre,
                                                         const vec3& u, double reach) {
  const double t0 = field.t0();
  const double f_centre = field.value(centre) - t0;
  double lo = 0, hi = 0;
  bool bracketed = false;
  for (int step = 1; step <= ray_march_steps && !bracketed; ++step) {
    const double t = reach * step / ray_march_steps;
    const double f = field.value(centre + u * t) - t0;
    if ((f > 0) != (f_centre > 0)) {
      hi = t;
      bracketed = true;
    } else {
      lo = t;
    }
  }
  if (!bracketed) return std::nullopt;
  double t = (lo + hi) / 2;
  for (int iteration = 0; iteration < 100; ++iteration) {
    vec3 gradient;
    const vec3 p = centre + u * t;
    const double f = field.value_and_gradient(p, gradient) - t0;
    const double g = norm(gradient);
    if (!(g > 0)) return std::nullopt;
    if (std::abs(f) <= 1e-12 * g || hi - lo < 1e-12) return std::pair{p, -gradient / g};
    if ((f > 0) == (f_centre > 0)) lo = t;
    else hi = t;
    const double slope = dot(gradient, u);
    const double newton = slope != 0 ? t - f / slope : lo;
    t = newton > lo && newton < hi ? newton : (lo + hi) / 2;
  }
  return std::nullopt;
}

/// Whether face t of `small` agrees with the field normals at its corners (its normal against the sum of theirs).
bool face_agrees(const small_mesh& small, const triangle& t) {
  const vec3 n = area_vector(small.positions[t[0]], small.positions[t[1]], small.positions[t[2]]);
  return dot(n, small.normals[t[0]] + small.normals[t[1]] + small.normals[t[2]]) > 0;
}

/// The certificate's orientation test of a component (analysis_topology.hpp: component_normal_agreement): the sum
/// over its faces of their area vectors against their corners' normals is positive. A coarse mesh of a tiny,
/// non-convex cavity may have a face turned against its corners' normals and still pass it.
bool agrees_with_field(const small_mesh& small) {
  double sum = 0;
  for (const triangle& t : small.triangles) {
    sum += dot(area_vector(small.positions[t[0]], small.positions[t[1]], small.positions[t[2]]),
               small.normals[t[0]] + small.normals[t[1]] + small.normals[t[2]]);
  }
  return sum > 0;
}

double worst_quality(const small_mesh& small) {
  double worst = 1;
  for (const triangle& t : small.triangles) {
    worst = std::min(worst, triangle_quality(small.positions[t[0]], small.positions[t[1]], small.positions[t[2]]));
  }
  return worst;
}

/// The component made again on rays from `centre` in the directions `u` (hull faces `faces`); nullopt when a ray
/// misses the surface or a face turns the wrong way about the centre (then the polyhedron would not be embedded).
std::optional<small_mesh> star_on_rays(const gaussian_field& field, const vec3& centre, const std::vector<vec3>& u,
                                       const std::vector<triangle>& faces, double reach, bool cavity) {
  small_mesh star;
  for (const vec3& direction : u) {
    const auto hit = first_surface_point(field, centre, direction, reach);
    if (!hit) return std::nullopt;
    star.positions.push_back(hit->first);
    star.normals.push_back(hit->second);
  }
  for (triangle face : faces) {
    const vec3 &a = star.positions[face[0]], &b = star.positions[face[1]], &c = star.positions[face[2]];
    if (!(dot(area_vector(a, b, c), (a + b + c) / 3.0 - centre) > 0)) return std::nullopt;
    // Outward is away from the centre for a blob, towards it for a cavity (the field grows away from its centre).
    if (cavity) std::swap(face[1], face[2]);
    star.triangles.push_back(face);
  }
  return star;
}

/// Hill-climbs the worst triangle quality of `small` (connectivity kept): each vertex in turn tries
/// polish_directions moves in its tangent plane, put back onto the surface, and keeps one that raises the worst
/// quality of its triangles (so never lowering the component's) and turns none of them against the field normals;
/// the step halves when no vertex moves. This is the
/// relaxation the iterations refuse here (see the file comment).
void polish(small_mesh& small, const gaussian_field& field, double step, double tolerance) {
  std::vector<std::vector<std::uint32_t>> around(small.positions.size());
  for (std::uint32_t f = 0; f < small.triangles.size(); ++f) {
    for (const std::uint32_t v : small.triangles[f]) around[v].push_back(f);
  }
  // The worst quality of v's triangles, and how many of them are turned against their corners' normals.
  const auto around_v = [&](std::uint32_t v) {
    double worst = 1;
    int turned = 0;
    for (const std::uint32_t f : around[v]) {
      const triangle& t = small.triangles[f];
      worst = std::min(worst, triangle_quality(small.positions[t[0]], small.positions[t[1]], small.positions[t[2]]));
      if (!face_agrees(small, t)) ++turned;
    }
    return std::pair{worst, turned};
  };
  const auto good_enough = [&] { return worst_quality(small) >= polish_enough_quality; };
  for (; step > tolerance && !good_enough(); step /= 2) {
    bool moved = true;
    for (int sweep = 0; sweep < polish_sweeps_per_step && moved; ++sweep) {
      moved = false;
      for (std::uint32_t v = 0; v < small.positions.size(); ++v) {
        const vec3 n = small.normals[v];
        const vec3 e1 = normalized(cross(n, std::abs(n.x) < 0.9 ? vec3{1, 0, 0} : vec3{0, 1, 0}));
        const vec3 e2 = cross(n, e1);
        const vec3 start = small.positions[v], start_normal = small.normals[v];
        auto [best, turned] = around_v(v);
        vec3 best_position = start, best_normal = start_normal;
        for (int k = 0; k < polish_directions; ++k) {
          const double angle = 2 * std::numbers::pi * k / polish_directions;
          vec3 p = start + (e1 * std::cos(angle) + e2 * std::sin(angle)) * step;
          vec3 normal;
          if (!project_onto_surface(field, p, normal, 4 * step, 1e-11)) continue;
          small.positions[v] = p;
          small.normals[v] = normal;
          if (const auto [q, now_turned] = around_v(v); q > best && now_turned <= turned) {
            best = q;
            turned = now_turned;
            best_position = p;
            best_normal = normal;
          }
        }
        small.positions[v] = best_position;
        small.normals[v] = best_normal;
        moved = moved || best_position != start;
      }
    }
  }
}

/// The component's own triangles as a small mesh (vertices numbered in `component.vertices` order).
small_mesh as_small_mesh(const surface_mesh& mesh, const small_component& component) {
  small_mesh small;
  for (const std::uint32_t v : component.vertices) {
    small.positions.push_back(mesh.positions[v]);
    small.normals.push_back(mesh.normals[v]);
  }
  for (const std::uint32_t f : component.triangles) {
    triangle t = mesh.triangles[f];
    for (std::uint32_t& v : t) {
      v = static_cast<std::uint32_t>(std::lower_bound(component.vertices.begin(), component.vertices.end(), v) -
                                     component.vertices.begin());
    }
    small.triangles.push_back(t);
  }
  return small;
}

/// The best remake of `component` (see the file comment) when its worst triangle beats the component's; nullopt
/// otherwise.
std::optional<small_mesh> remade(const surface_mesh& mesh, const gaussian_field& field,
                                 const small_component& component, double target_edge) {
  const small_mesh old = as_small_mesh(mesh, component);
  vec3 centre{};
  for (const vec3& p : old.positions) centre += p;
  centre = centre / static_cast<double>(old.positions.size());
  const double diameter = component.diameter;
  double area = 0;
  for (const triangle& t : old.triangles) {
    area += norm(area_vector(old.positions[t[0]], old.positions[t[1]], old.positions[t[2]])) / 2;
  }
  const double old_quality = worst_quality(old);
  const double phi_centre = field.value(centre) - field.t0();
  if (phi_centre == 0) return std::nullopt;
  // As many vertices as triangles of edge L need (2V − 4 triangles), at least 4, never more than it had.
  const double ideal_triangle = std::sqrt(3.0) / 4 * target_edge * target_edge;
  const auto wanted = static_cast<std::size_t>(std::lround(area / ideal_triangle / 2 + 2));
  const std::size_t n = std::clamp<std::size_t>(wanted, 4, old.positions.size());
  const std::vector<vec3> base = spread_directions(n);
  const std::vector<triangle> faces = hull_of_directions(base);
  if (faces.empty()) return std::nullopt;
  const std::vector<vec3> axes = spread_directions(direction_rotations);
  const double golden_angle = std::numbers::pi * (3 - std::sqrt(5.0));
  std::optional<small_mesh> best_star;
  double best_star_quality = -1;
  for (int r = 0; r < direction_rotations; ++r) {
    std::vector<vec3> u;
    for (const vec3& d : base) u.push_back(rotated(d, axes[static_cast<std::size_t>(r)], golden_angle * (r + 1)));
    auto star = star_on_rays(field, centre, u, faces, ray_reach_in_diameters * diameter, phi_centre < 0);
    if (!star) continue;
    if (const double q = worst_quality(*star); q > best_star_quality && agrees_with_field(*star)) {
      best_star_quality = q;
      best_star = std::move(star);
    }
  }
  // The better of the two is polished, and kept if its worst triangle then beats the component's.
  small_mesh best = best_star && best_star_quality > old_quality ? std::move(*best_star) : old;
  polish(best, field, polish_first_step * diameter, polish_last_step * diameter);
  if (!(worst_quality(best) > old_quality && agrees_with_field(best))) return std::nullopt;
  return best;
}

/// Drops the triangles not alive and the vertices no triangle uses, the others keeping their order.
void compact(surface_mesh& mesh, const std::vector<char>& alive) {
  std::vector<char> used(mesh.positions.size(), 0);
  std::size_t kept_triangles = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!alive[f]) continue;
    mesh.triangles[kept_triangles++] = mesh.triangles[f];
    for (const std::uint32_t v : mesh.triangles[f]) used[v] = 1;
  }
  mesh.triangles.resize(kept_triangles);
  std::vector<std::uint32_t> number(mesh.positions.size(), 0);
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    if (!used[v]) continue;
    number[v] = next;
    mesh.positions[next] = mesh.positions[v];
    mesh.normals[next] = mesh.normals[v];
    ++next;
  }
  mesh.positions.resize(next);
  mesh.normals.resize(next);
  for (auto& t : mesh.triangles) {
    for (std::uint32_t& v : t) v = number[v];
  }
}

}  // namespace

std::size_t resample_small_components(surface_mesh& mesh, const gaussian_field& field, double target_edge) {
  const std::vector<small_component> components = find_small_components(mesh, target_edge);
  if (components.empty()) return 0;
  std::vector<std::optional<small_mesh>> stars(components.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, components.size(), 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) stars[c] = remade(mesh, field, components[c], target_edge);
  });
  // Append every new component, its old triangles removed; then undo those whose triangles the certificate's tests
  // refuse, until none is refused (an undone component's old triangles are tested again against the others).
  std::vector<char> alive(mesh.triangles.size(), 1);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> new_triangles(components.size());  // [first, end)
  for (std::size_t c = 0; c < components.size(); ++c) {
    const auto first = static_cast<std::uint32_t>(mesh.triangles.size());
    new_triangles[c] = {first, first};
    if (!stars[c]) continue;
    const auto offset = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), stars[c]->positions.begin(), stars[c]->positions.end());
    mesh.normals.insert(mesh.normals.end(), stars[c]->normals.begin(), stars[c]->normals.end());
    for (triangle t : stars[c]->triangles) {
      for (std::uint32_t& v : t) v += offset;
      mesh.triangles.push_back(t);
      alive.push_back(1);
    }
    new_triangles[c].second = static_cast<std::uint32_t>(mesh.triangles.size());
    for (const std::uint32_t f : components[c].triangles) alive[f] = 0;
  }
  const auto set_replaced = [&](std::size_t c, bool replaced) {
    for (std::uint32_t f = new_triangles[c].first; f < new_triangles[c].second; ++f) alive[f] = replaced ? 1 : 0;
    for (const std::uint32_t f : components[c].triangles) alive[f] = replaced ? 0 : 1;
  };
  const auto component_of_new = [&](std::uint32_t f) {
    return static_cast<std::size_t>(
        std::partition_point(new_triangles.begin(), new_triangles.end(),
                             [f](const auto& range) { return range.second <= f; }) -
        new_triangles.begin());
  };
  // The first look searches the mesh around the new triangles; later ones test them against the old triangles the
  // last undoing restored, the rest being unchanged since.
  std::vector<std::uint32_t> restored;
  for (bool first_look = true; first_look || !restored.empty(); first_look = false) {
    std::vector<std::uint32_t> moving;
    for (std::uint32_t f = new_triangles.front().first; f < mesh.triangles.size(); ++f) {
      if (alive[f]) moving.push_back(f);
    }
    const std::vector<std::uint32_t> failing = first_look ? failing_moved_triangles(mesh, alive, std::move(moving))
                                                          : failing_moved_triangles_among(mesh, moving, restored);
    restored.clear();
    for (const std::uint32_t f : failing) {
      const std::size_t c = component_of_new(f);
      if (!alive[new_triangles[c].first]) continue;
      set_replaced(c, false);
      restored.insert(restored.end(), components[c].triangles.begin(), components[c].triangles.end());
    }
  }
  std::size_t replaced = 0;
  for (std::size_t c = 0; c < components.size(); ++c) {
    if (new_triangles[c].first < new_triangles[c].second && alive[new_triangles[c].first]) ++replaced;
  }
  compact(mesh, alive);
  return replaced;
}

}  // namespace tracemesh::detail
