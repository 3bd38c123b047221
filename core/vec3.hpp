#pragma once
/// @file vec3.hpp
/// A small 3-vector of doubles (Å) with the arithmetic the mesher needs.

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>

namespace tracemesh {

struct vec3 {
  double x = 0, y = 0, z = 0;

  constexpr double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr vec3& operator+=(const vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  constexpr vec3& operator-=(const vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  constexpr vec3& operator*=(double s) { x *= s; y *= s; z *= s; return *this; }
  friend constexpr vec3 operator+(vec3 a, const vec3& b) { return a += b; }
  friend constexpr vec3 operator-(vec3 a, const vec3& b) { return a -= b; }
  friend constexpr vec3 operator-(const vec3& a) { return {-a.x, -a.y, -a.z}; }
  friend constexpr vec3 operator*(vec3 a, double s) { return a *= s; }
  friend constexpr vec3 operator*(double s, vec3 a) { return a *= s; }
  friend constexpr vec3 operator/(const vec3& a, double s) { return {a.x / s, a.y / s, a.z / s}; }
  friend constexpr bool operator==(const vec3&, const vec3&) = default;
};

constexpr double dot(const vec3& a, const vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr vec3 cross(const vec3& a, const vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
constexpr double squared_norm(const vec3& a) { return dot(a, a); }
inline double norm(const vec3& a) { return std::sqrt(dot(a, a)); }
inline double distance(const vec3& a, const vec3& b) { return norm(a - b); }
/// a / |a|, or the zero vector when |a| == 0.
inline vec3 normalized(const vec3& a) {
  const double n = norm(a);
  return n > 0 ? a / n : vec3{};
}

/// Axis-aligned closed box, Å.
struct box3 {
  vec3 lo, hi;

  /// The box of one point.
  static constexpr box3 around(const vec3& p) { return {p, p}; }
  /// Grows the box to hold p.
  constexpr void include(const vec3& p) {
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
    }
  }
  constexpr bool contains(const vec3& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
  constexpr bool contains(const box3& inner) const { return contains(inner.lo) && contains(inner.hi); }
  constexpr bool meets(const box3& other) const {
    for (int axis = 0; axis < 3; ++axis) {
      if (other.hi[axis] < lo[axis] || other.lo[axis] > hi[axis]) return false;
    }
    return true;
  }
};

/// The smallest box holding the points (at least one). (Templates rather than std::span: this header is also
/// read by the structure reader, which builds as C++17.)
template <class Points>
box3 bounds_of(const Points& points) {
  box3 b = box3::around(*std::begin(points));
  for (const vec3& p : points) b.include(p);
  return b;
}

/// The smallest box holding positions[i] for every i of `indices` (at least one): a triangle, a component.
template <class Positions, class Indices>
box3 bounds_of(const Positions& positions, const Indices& indices) {
  box3 b = box3::around(positions[*std::begin(indices)]);
  for (const auto i : indices) b.include(positions[i]);
  return b;
}

inline std::array<float, 3> to_float3(const vec3& a) {
  return {static_cast<float>(a.x), static_cast<float>(a.y), static_cast<float>(a.z)};
}

}  // namespace tracemesh
