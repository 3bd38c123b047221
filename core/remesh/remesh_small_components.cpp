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
/// Polishing stops once every triangle is at least this good (equilateral: 1); lengthening keeps them so.
constexpr double polish_enough_quality = 0.9;
/// Sweeps over the vertices at one step length, at most (each sweep moves every vertex that can improve).
constexpr int polish_sweeps_per_step = 4;
/// The Fibonacci set's step in longitude, and the step between its rotations.
double golden_angle() { return std::numbers::pi * (3 - std::sqrt(5.0)); }

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
    const box3 box = bounds_of(mesh.positions, c.vertices);
    c.diameter = distance(box.lo, box.hi);
    if (c.diameter <= max_diameter_in_edges * target_edge) small.push_back(std::move(c));
  }
  return small;
}

/// n unit vectors spread evenly over the sphere (a Fibonacci set).
std::vector<vec3> spread_directions(std::size_t n) {
  std::vector<vec3> directions;
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1 - 2 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double rho = std::sqrt(1 - z * z);
    const double angle = golden_angle() * static_cast<double>(i);
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

/// Face t's area vector against the sum of the field normals at its corners: positive where it agrees with them.
double agreement(const small_mesh& small, const triangle& t) {
  const vec3 n = area_vector(small.positions[t[0]], small.positions[t[1]], small.positions[t[2]]);
  return dot(n, small.normals[t[0]] + small.normals[t[1]] + small.normals[t[2]]);
}

/// The certificate's orientation test of a component (analysis_topology.hpp: component_normal_agreement): the sum
/// of its faces' agreements is positive. A coarse mesh of a tiny, non-convex cavity may have a face turned against
/// its corners' normals and still pass it.
bool agrees_with_field(const small_mesh& small) {
  double sum = 0;
  for (const triangle& t : small.triangles) sum += agreement(small, t);
  return sum > 0;
}

/// Whether some face of `small` points against the field normals at all three of its corners (a fold, which the
/// certificate refuses: detail::is_folded). A coarse remake of a tiny non-convex cavity can pass agrees_with_field
/// with one.
bool has_fold(const small_mesh& small) {
  return std::any_of(small.triangles.begin(), small.triangles.end(), [&](const triangle& t) {
    const vec3 n = area_vector(small.positions[t[0]], small.positions[t[1]], small.positions[t[2]]);
    return dot(n, small.normals[t[0]]) < 0 && dot(n, small.normals[t[1]]) < 0 && dot(n, small.normals[t[2]]) < 0;
  });
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

/// What a move of one vertex is judged by, from its triangles.
struct vertex_score {
  double worst_quality = 1;      ///< of its triangles
  double shortest_edge = 1e300;  ///< of its edges
  int turned = 0;                ///< its triangles turned against their corners' field normals
};

/// Hill-climbs `small` (connectivity kept): each vertex in turn tries polish_directions moves in its tangent plane,
/// put back onto the surface, and takes the best one by `better(candidate, best so far)`, a vertex_score order; the
/// step halves when no vertex moves, from `step` down to `tolerance`, or until `done()`.
template <class Better, class Done>
void hill_climb(small_mesh& small, const gaussian_field& field, double step, double tolerance, Better better,
                Done done) {
  std::vector<std::vector<std::uint32_t>> around(small.positions.size());
  for (std::uint32_t f = 0; f < small.triangles.size(); ++f) {
    for (const std::uint32_t v : small.triangles[f]) around[v].push_back(f);
  }
  const auto score_at = [&](std::uint32_t v) {
    vertex_score score;
    const vec3& at = small.positions[v];
    for (const std::uint32_t f : around[v]) {
      const triangle& t = small.triangles[f];
      const vec3 &a = small.positions[t[0]], &b = small.positions[t[1]], &c = small.positions[t[2]];
      score.worst_quality = std::min(score.worst_quality, triangle_quality(a, b, c));
      for (const std::uint32_t w : t) {
        if (w != v) score.shortest_edge = std::min(score.shortest_edge, distance(at, small.positions[w]));
      }
      if (!(agreement(small, t) > 0)) ++score.turned;
    }
    return score;
  };
  for (; step > tolerance && !done(); step /= 2) {
    bool moved = true;
    for (int sweep = 0; sweep < polish_sweeps_per_step && moved; ++sweep) {
      moved = false;
      for (std::uint32_t v = 0; v < small.positions.size(); ++v) {
        const vec3 n = small.normals[v];
        const vec3 e1 = normalized(cross(n, std::abs(n.x) < 0.9 ? vec3{1, 0, 0} : vec3{0, 1, 0}));
        const vec3 e2 = cross(n, e1);
        const vec3 start = small.positions[v], start_normal = small.normals[v];
        vertex_score best = score_at(v);
        vec3 best_position = start, best_normal = start_normal;
        for (int k = 0; k < polish_directions; ++k) {
          const double angle = 2 * std::numbers::pi * k / polish_directions;
          vec3 p = start + (e1 * std::cos(angle) + e2 * std::sin(angle)) * step;
          vec3 normal;
          if (!project_onto_surface(field, p, normal, 4 * step, 1e-11)) continue;
          small.positions[v] = p;
          small.normals[v] = normal;
          if (const vertex_score now = score_at(v); better(now, best)) {
            best = now;
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

/// Raises the worst triangle quality of `small` until it reaches polish_enough_quality, never turning more
/// triangles against the field normals.
void polish(small_mesh& small, const gaussian_field& field, double diameter) {
  hill_climb(
      small, field, polish_first_step * diameter, polish_last_step * diameter,
      [](const vertex_score& now, const vertex_score& best) {
        return now.worst_quality > best.worst_quality && now.turned <= best.turned;
      },
      [&] { return worst_quality(small) >= polish_enough_quality; });
}

/// Lengthens the shortest edges of a polished `small` while its worst quality stays at polish_enough_quality (or
/// where polishing left it, if lower), never turning more triangles against the field normals.
void lengthen_shortest_edges(small_mesh& small, const gaussian_field& field, double diameter) {
  const double floor = std::min(polish_enough_quality, worst_quality(small));
  hill_climb(
      small, field, polish_first_step * diameter, polish_last_step * diameter,
      [floor](const vertex_score& now, const vertex_score& best) {
        return now.shortest_edge > best.shortest_edge && now.worst_quality >= floor && now.turned <= best.turned;
      },
      [] { return false; });
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

/// A component made again: lengthened (its shortest edges lengthened after polishing) and, when that differs and
/// also beats the component, polished only, the fallback when the lengthened one meets the mesh.
struct remake {
  small_mesh lengthened;
  std::optional<small_mesh> polished;
};

/// The best remake of `component` (see the file comment) when its worst triangle beats the component's; nullopt
/// otherwise.
std::optional<remake> remade(const surface_mesh& mesh, const gaussian_field& field,
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
  std::optional<small_mesh> best_star;
  double best_star_quality = -1;
  for (int r = 0; r < direction_rotations; ++r) {
    std::vector<vec3> u;
    for (const vec3& d : base) u.push_back(rotated(d, axes[static_cast<std::size_t>(r)], golden_angle() * (r + 1)));
    auto star = star_on_rays(field, centre, u, faces, ray_reach_in_diameters * diameter, phi_centre < 0);
    if (!star) continue;
    const double q = worst_quality(*star);
    if (q > best_star_quality && agrees_with_field(*star) && !has_fold(*star)) {
      best_star_quality = q;
      best_star = std::move(star);
    }
  }
  // The better of the two is polished, and kept if its worst triangle then beats the component's. A remake without a
  // fold also beats a component with one, whatever its worst triangle.
  const bool old_folded = has_fold(old);
  small_mesh polished =
      best_star && (best_star_quality > old_quality || old_folded) ? std::move(*best_star) : old;
  polish(polished, field, diameter);
  const auto beats_old = [&](const small_mesh& made) {
    return (worst_quality(made) > old_quality || old_folded) && agrees_with_field(made) && !has_fold(made);
  };
  if (!beats_old(polished)) return std::nullopt;
  remake made{polished, std::nullopt};
  lengthen_shortest_edges(made.lengthened, field, diameter);
  if (!beats_old(made.lengthened)) return remake{std::move(polished), std::nullopt};
  if (made.lengthened.positions != polished.positions) made.polished = std::move(polished);
  return made;
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
  std::vector<std::optional<remake>> remakes(components.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, components.size(), 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      remakes[c] = remade(mesh, field, components[c], target_edge);
    }
  });
  // Append every lengthened remake, the component's old triangles removed. Then, until the certificate's tests
  // refuse none, a refused remake falls back to its polished one (its corners move) or, without one, is undone (its
  // old triangles put back).
  std::vector<char> alive(mesh.triangles.size(), 1);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> new_triangles(components.size());  // [first, end)
  std::vector<std::uint32_t> first_vertex(components.size());
  for (std::size_t c = 0; c < components.size(); ++c) {
    const auto first = static_cast<std::uint32_t>(mesh.triangles.size());
    new_triangles[c] = {first, first};
    if (!remakes[c]) continue;
    const small_mesh& made = remakes[c]->lengthened;
    first_vertex[c] = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), made.positions.begin(), made.positions.end());
    mesh.normals.insert(mesh.normals.end(), made.normals.begin(), made.normals.end());
    for (triangle t : made.triangles) {
      for (std::uint32_t& v : t) v += first_vertex[c];
      mesh.triangles.push_back(t);
      alive.push_back(1);
    }
    new_triangles[c].second = static_cast<std::uint32_t>(mesh.triangles.size());
    for (const std::uint32_t f : components[c].triangles) alive[f] = 0;
  }
  const auto undo = [&](std::size_t c) {
    for (std::uint32_t f = new_triangles[c].first; f < new_triangles[c].second; ++f) alive[f] = 0;
    for (const std::uint32_t f : components[c].triangles) alive[f] = 1;
  };
  const auto fall_back_to_polished = [&](std::size_t c) {
    small_mesh& polished = *remakes[c]->polished;
    std::copy(polished.positions.begin(), polished.positions.end(), mesh.positions.begin() + first_vertex[c]);
    std::copy(polished.normals.begin(), polished.normals.end(), mesh.normals.begin() + first_vertex[c]);
    remakes[c]->polished.reset();
  };
  const auto component_of_new = [&](std::uint32_t f) {
    return static_cast<std::size_t>(
        std::partition_point(new_triangles.begin(), new_triangles.end(),
                             [f](const auto& range) { return range.second <= f; }) -
        new_triangles.begin());
  };
  // Each look searches the mesh around the triangles that moved (at first, every new one) and tests every new one
  // against the old triangles the last undoing restored; the rest is unchanged since it was tested.
  std::vector<std::uint32_t> moved, restored;
  for (std::uint32_t f = new_triangles.front().first; f < mesh.triangles.size(); ++f) moved.push_back(f);
  while (!moved.empty() || !restored.empty()) {
    std::vector<std::uint32_t> failing = failing_moved_triangles(mesh, alive, std::move(moved));
    if (!restored.empty()) {
      std::vector<std::uint32_t> new_alive;
      for (std::uint32_t f = new_triangles.front().first; f < mesh.triangles.size(); ++f) {
        if (alive[f]) new_alive.push_back(f);
      }
      const std::vector<std::uint32_t> more = failing_moved_triangles_among(mesh, std::move(new_alive), restored);
      failing.insert(failing.end(), more.begin(), more.end());
    }
    moved.clear();
    restored.clear();
    std::vector<std::size_t> refused;
    for (const std::uint32_t f : failing) refused.push_back(component_of_new(f));
    std::sort(refused.begin(), refused.end());
    refused.erase(std::unique(refused.begin(), refused.end()), refused.end());
    for (const std::size_t c : refused) {
      if (!alive[new_triangles[c].first]) continue;
      if (remakes[c]->polished) {
        fall_back_to_polished(c);
        for (std::uint32_t f = new_triangles[c].first; f < new_triangles[c].second; ++f) moved.push_back(f);
      } else {
        undo(c);
        restored.insert(restored.end(), components[c].triangles.begin(), components[c].triangles.end());
      }
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
