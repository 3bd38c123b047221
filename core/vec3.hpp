#pragma once
/// @file vec3.hpp
/// A small 3-vector of doubles (Å) with the arithmetic the mesher needs.

#include <array>
#include <cmath>

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
inline std::array<float, 3> to_float3(const vec3& a) {
  return {static_cast<float>(a.x), static_cast<float>(a.y), static_cast<float>(a.z)};
}

}  // namespace tracemesh
