#include "core/analysis/triangle_intersection.hpp"

#include <algorithm>
#include <cmath>

#include "core/analysis/analysis_predicates.hpp"

namespace tracemesh::detail {
namespace {

/// The axis along which the normal of (a, b, c) is largest: dropping it projects the triangle's plane onto a
/// coordinate plane without collapsing it. Any axis whose exact normal component is non-zero would do; the
/// largest computed one is safely non-zero for a non-degenerate triangle.
int dominant_axis(const vec3& a, const vec3& b, const vec3& c) {
  const vec3 normal = cross(b - a, c - a);
  const double nx = std::abs(normal.x), ny = std::abs(normal.y), nz = std::abs(normal.z);
  if (nx >= ny && nx >= nz) return 0;
  return ny >= nz ? 1 : 2;
}

point2 project(const vec3& p, int dropped_axis) { return {p[(dropped_axis + 1) % 3], p[(dropped_axis + 2) % 3]}; }

int orient(const point2& a, const point2& b, const point2& c) { return orient2d(a.x, a.y, b.x, b.y, c.x, c.y); }

/// True when the signs do not include both a strictly positive and a strictly negative one.
bool signs_agree(int s0, int s1, int s2) {
  const bool any_positive = s0 > 0 || s1 > 0 || s2 > 0;
  const bool any_negative = s0 < 0 || s1 < 0 || s2 < 0;
  return !(any_positive && any_negative);
}

bool strictly_same_side(int s0, int s1, int s2) { return (s0 > 0 && s1 > 0 && s2 > 0) || (s0 < 0 && s1 < 0 && s2 < 0); }

/// p is collinear with segment [a, b]; true when it lies within it.
bool within_collinear_segment(const point2& a, const point2& b, const point2& p) {
  return std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
         p.y <= std::max(a.y, b.y);
}

bool point_in_triangle_2d(const point2& p, const point2 (&t)[3]) {
  return signs_agree(orient(t[0], t[1], p), orient(t[1], t[2], p), orient(t[2], t[0], p));
}

/// Closed segment [a, b] against closed triangle t, all in one plane.
bool coplanar_segment_meets_triangle(const vec3& a, const vec3& b, const triangle_corners& t) {
  const int axis = dominant_axis(t[0], t[1], t[2]);
  const point2 a2 = project(a, axis), b2 = project(b, axis);
  const point2 t2[3] = {project(t[0], axis), project(t[1], axis), project(t[2], axis)};
  return point_in_triangle_2d(a2, t2) || point_in_triangle_2d(b2, t2) || segments_intersect_2d(a2, b2, t2[0], t2[1]) ||
         segments_intersect_2d(a2, b2, t2[1], t2[2]) || segments_intersect_2d(a2, b2, t2[2], t2[0]);
}

/// Closed segment [a, b] against closed triangle t, given a_side, b_side = orient3d(t, a), orient3d(t, b).
bool segment_meets_triangle(const vec3& a, const vec3& b, int a_side, int b_side, const triangle_corners& t) {
  if (a_side * b_side > 0) return false;  // both strictly on one side of t's plane
  if (a_side == 0 && b_side == 0) return coplanar_segment_meets_triangle(a, b, t);
  // The segment crosses or touches the plane at one point; the line ab passes through the closed triangle when it
  // winds the same way (or not at all) around each of its edges.
  return signs_agree(orient3d(a, b, t[0], t[1]), orient3d(a, b, t[1], t[2]), orient3d(a, b, t[2], t[0]));
}

std::array<int, 3> sides_of_plane(const triangle_corners& plane, const triangle_corners& points) {
  return {orient3d(plane[0], plane[1], plane[2], points[0]), orient3d(plane[0], plane[1], plane[2], points[1]),
          orient3d(plane[0], plane[1], plane[2], points[2])};
}

/// Rotates the corner indices of t so that t[shared] comes first.
std::array<std::uint32_t, 3> rotate_to_front(const std::array<std::uint32_t, 3>& t, int shared) {
  return {t[shared], t[(shared + 1) % 3], t[(shared + 2) % 3]};
}

}  // namespace

bool segments_intersect_2d(const point2& a, const point2& b, const point2& c, const point2& d) {
  const int c_side = orient(a, b, c), d_side = orient(a, b, d);
  const int a_side = orient(c, d, a), b_side = orient(c, d, b);
  if (c_side * d_side < 0 && a_side * b_side < 0) return true;  // proper crossing
  return (c_side == 0 && within_collinear_segment(a, b, c)) || (d_side == 0 && within_collinear_segment(a, b, d)) ||
         (a_side == 0 && within_collinear_segment(c, d, a)) || (b_side == 0 && within_collinear_segment(c, d, b));
}

bool triangles_intersect(const triangle_corners& t, const triangle_corners& u) {
  const std::array<int, 3> t_sides = sides_of_plane(u, t);
  if (strictly_same_side(t_sides[0], t_sides[1], t_sides[2])) return false;
  const std::array<int, 3> u_sides = sides_of_plane(t, u);
  if (strictly_same_side(u_sides[0], u_sides[1], u_sides[2])) return false;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    if (segment_meets_triangle(t[i], t[j], t_sides[i], t_sides[j], u)) return true;
  }
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    if (segment_meets_triangle(u[i], u[j], u_sides[i], u_sides[j], t)) return true;
  }
  return false;
}

// Along the line where the planes meet (or any ray from v in the common plane), each triangle covers a segment
// starting at v and ending on its edge opposite v. The triangles share more than v exactly when the shorter of
// these segments ends on its opposite edge inside the other triangle: so testing the two opposite edges suffices.
bool triangles_meet_beyond_shared_vertex(const vec3& v, const vec3& a, const vec3& b, const vec3& c, const vec3& d) {
  const triangle_corners t = {v, a, b};
  const triangle_corners u = {v, c, d};
  if (segment_meets_triangle(a, b, orient3d(v, c, d, a), orient3d(v, c, d, b), u)) return true;
  return segment_meets_triangle(c, d, orient3d(v, a, b, c), orient3d(v, a, b, d), t);
}

bool triangles_fold_over_shared_edge(const vec3& p, const vec3& q, const vec3& a, const vec3& b) {
  if (orient3d(p, q, a, b) != 0) return false;  // distinct planes meet only along pq
  const int axis = dominant_axis(p, q, a);
  const point2 p2 = project(p, axis), q2 = project(q, axis);
  return orient(p2, q2, project(a, axis)) * orient(p2, q2, project(b, axis)) > 0;
}

bool mesh_triangles_intersect(const std::vector<vec3>& positions, const std::array<std::uint32_t, 3>& t,
                              const std::array<std::uint32_t, 3>& u) {
  int shared = 0;
  int t_shared = -1, u_shared = -1;  // a shared corner of each (the only one when shared == 1)
  int t_unshared = -1, u_unshared = -1;
  for (int i = 0; i < 3; ++i) {
    bool found = false;
    for (int j = 0; j < 3; ++j) {
      if (t[i] == u[j]) {
        ++shared;
        t_shared = i;
        u_shared = j;
        found = true;
      }
    }
    if (!found) t_unshared = i;
  }
  for (int j = 0; j < 3; ++j) {
    if (u[j] != t[0] && u[j] != t[1] && u[j] != t[2]) u_unshared = j;
  }
  const auto at = [&positions](std::uint32_t index) -> const vec3& { return positions[index]; };
  switch (shared) {
    case 0:
      return triangles_intersect({at(t[0]), at(t[1]), at(t[2])}, {at(u[0]), at(u[1]), at(u[2])});
    case 1: {
      const auto tr = rotate_to_front(t, t_shared);
      const auto ur = rotate_to_front(u, u_shared);
      return triangles_meet_beyond_shared_vertex(at(tr[0]), at(tr[1]), at(tr[2]), at(ur[1]), at(ur[2]));
    }
    case 2: {
      const auto tr = rotate_to_front(t, t_unshared);  // (a, p, q) with pq the shared edge
      return triangles_fold_over_shared_edge(at(tr[1]), at(tr[2]), at(tr[0]), at(u[u_unshared]));
    }
    default:
      return true;  // the same three vertices: the faces coincide
  }
}

}  // namespace tracemesh::detail
