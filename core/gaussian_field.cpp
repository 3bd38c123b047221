#include "core/gaussian_field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace tracemesh {
namespace {

/// ∫_U^∞ u² e^(−a u²) du for a > 0 (integration by parts + erfc).
double gaussian_moment_tail(double a, double u) {
  return u * std::exp(-a * u * u) / (2 * a) + std::sqrt(M_PI) / (4 * a * std::sqrt(a)) * std::erfc(std::sqrt(a) * u);
}

/// Neglected φ beyond cutoff factor u: the kernel's tail integrated over a uniform density of atom centres.
double tail_bound(double d, double max_radius, double u) {
  const double a = -d;
  return max_atom_number_density * 4 * M_PI * max_radius * max_radius * max_radius * std::exp(a) *
         gaussian_moment_tail(a, u);
}

// Cell edge = half the largest cutoff, so a point's neighbours lie within ±2 cells.
constexpr int cell_reach = 2;

}  // namespace

double cutoff_factor(double d, double t0, double max_radius, double tolerance) {
  const double target = tolerance * t0;
  double lo = 1.0, hi = 1.0;
  while (tail_bound(d, max_radius, hi) > target && hi < 1e3) hi *= 2;
  for (int i = 0; i < 60; ++i) {  // bisection on a monotone function
    const double mid = 0.5 * (lo + hi);
    (tail_bound(d, max_radius, mid) > target ? lo : hi) = mid;
  }
  return hi;
}

gaussian_field::gaussian_field(const molecule& mol, double d, double t0) : d_(d), t0_(t0) {
  std::vector<std::uint32_t> contributing;
  contributing.reserve(mol.atoms.size());
  for (std::uint32_t i = 0; i < mol.atoms.size(); ++i) {
    if (mol.atoms[i].radius > 0) {
      contributing.push_back(i);
      max_radius_ = std::max(max_radius_, mol.atoms[i].radius);
    }
  }
  if (contributing.empty()) return;

  const double u = cutoff_factor(d, t0, max_radius_);
  cutoff_error_bound_ = tail_bound(d, max_radius_, u);
  max_cutoff_ = u * max_radius_;
  cell_size_ = max_cutoff_ / cell_reach;

  atom_bounds_.lo = atom_bounds_.hi = mol.atoms[contributing.front()].center;
  data_.reserve(contributing.size());
  for (const std::uint32_t i : contributing) {
    const atom& a = mol.atoms[i];
    const double cutoff = u * a.radius;
    data_.push_back({a.center.x, a.center.y, a.center.z, 1.0 / (a.radius * a.radius), cutoff * cutoff, i});
    for (int axis = 0; axis < 3; ++axis) {
      atom_bounds_.lo[axis] = std::min(atom_bounds_.lo[axis], a.center[axis]);
      atom_bounds_.hi[axis] = std::max(atom_bounds_.hi[axis], a.center[axis]);
    }
  }

  // Sort atoms by (cell x, cell y, cell z, original index): each (x, y) row of cells is one contiguous range.
  struct keyed {
    std::int64_t cx, cy, cz;
    std::uint32_t k;
  };
  std::vector<keyed> keys(data_.size());
  for (std::uint32_t k = 0; k < data_.size(); ++k) {
    keys[k] = {cell_of(data_[k].x), cell_of(data_[k].y), cell_of(data_[k].z), k};
  }
  std::sort(keys.begin(), keys.end(), [&](const keyed& a, const keyed& b) {
    if (a.cx != b.cx) return a.cx < b.cx;
    if (a.cy != b.cy) return a.cy < b.cy;
    if (a.cz != b.cz) return a.cz < b.cz;
    return data_[a.k].original_index < data_[b.k].original_index;
  });
  std::vector<atom_data> sorted(data_.size());
  cell_z_.resize(data_.size());
  rows_.reserve(data_.size() / 4 + 1);
  for (std::uint32_t n = 0; n < keys.size(); ++n) {
    sorted[n] = data_[keys[n].k];
    cell_z_[n] = static_cast<std::int32_t>(keys[n].cz);
    const std::uint64_t key = row_key(keys[n].cx, keys[n].cy);
    auto [it, inserted] = rows_.try_emplace(key, row_span{n, n + 1});
    if (!inserted) it->second.end = n + 1;
  }
  data_ = std::move(sorted);
}

std::int64_t gaussian_field::cell_of(double coordinate) const {
  return static_cast<std::int64_t>(std::floor(coordinate / cell_size_));
}

std::uint64_t gaussian_field::row_key(std::int64_t cx, std::int64_t cy) {
  return (static_cast<std::uint64_t>(cx + (1LL << 31)) << 32) ^ static_cast<std::uint64_t>(cy + (1LL << 31));
}

template <class Visitor>
void gaussian_field::visit_near(const vec3& p, Visitor&& visit) const {
  const std::int64_t cx = cell_of(p.x), cy = cell_of(p.y);
  const std::int64_t cz = cell_of(p.z);
  for (std::int64_t ix = cx - cell_reach; ix <= cx + cell_reach; ++ix) {
    for (std::int64_t iy = cy - cell_reach; iy <= cy + cell_reach; ++iy) {
      const auto row = rows_.find(row_key(ix, iy));
      if (row == rows_.end()) continue;
      const auto first = cell_z_.begin() + row->second.begin;
      const auto last = cell_z_.begin() + row->second.end;
      auto it = std::lower_bound(first, last, cz - cell_reach);
      for (; it != last && *it <= cz + cell_reach; ++it) {
        const atom_data& a = data_[static_cast<std::size_t>(it - cell_z_.begin())];
        const double dx = p.x - a.x, dy = p.y - a.y, dz = p.z - a.z;
        const double r2 = dx * dx + dy * dy + dz * dz;
        if (r2 < a.cutoff2) visit(a, dx, dy, dz, r2);
      }
    }
  }
}

double gaussian_field::value(const vec3& p) const {
  double phi = 0;
  visit_near(p, [&](const atom_data& a, double, double, double, double r2) {
    phi += std::exp(d_ * (r2 * a.inv_r2 - 1));
  });
  return phi;
}

double gaussian_field::value_and_gradient(const vec3& p, vec3& gradient) const {
  double phi = 0;
  vec3 g{};
  visit_near(p, [&](const atom_data& a, double dx, double dy, double dz, double r2) {
    const double k = std::exp(d_ * (r2 * a.inv_r2 - 1));
    phi += k;
    const double s = 2 * d_ * a.inv_r2 * k;  // ∂/∂x of exp(d(|x−c|²/r² − 1)) = 2d(x−c)/r² · kernel
    g.x += s * dx;
    g.y += s * dy;
    g.z += s * dz;
  });
  gradient = g;
  return phi;
}

std::uint32_t gaussian_field::dominant_atom(const vec3& p) const {
  double best = -1;
  std::uint32_t best_index = std::numeric_limits<std::uint32_t>::max();
  visit_near(p, [&](const atom_data& a, double, double, double, double r2) {
    const double k = std::exp(d_ * (r2 * a.inv_r2 - 1));
    if (k > best || (k == best && a.original_index < best_index)) {
      best = k;
      best_index = a.original_index;
    }
  });
  if (best_index == std::numeric_limits<std::uint32_t>::max() && !data_.empty()) {
    // Beyond every cutoff (cannot happen on the surface); fall back to the nearest centre.
    double nearest = std::numeric_limits<double>::infinity();
    for (const atom_data& a : data_) {
      const double r2 = squared_norm(p - vec3{a.x, a.y, a.z});
      if (r2 < nearest || (r2 == nearest && a.original_index < best_index)) {
        nearest = r2;
        best_index = a.original_index;
      }
    }
  }
  return best_index;
}

gaussian_field::point_probe gaussian_field::probe(const vec3& p) const {
  point_probe out{0, {}, std::numeric_limits<std::uint32_t>::max()};
  double best = -1;
  visit_near(p, [&](const atom_data& a, double dx, double dy, double dz, double r2) {
    const double k = std::exp(d_ * (r2 * a.inv_r2 - 1));
    out.value += k;
    const double s = 2 * d_ * a.inv_r2 * k;
    out.gradient += vec3{s * dx, s * dy, s * dz};
    if (k > best || (k == best && a.original_index < out.dominant_atom)) {
      best = k;
      out.dominant_atom = a.original_index;
    }
  });
  if (out.dominant_atom == std::numeric_limits<std::uint32_t>::max()) out.dominant_atom = dominant_atom(p);
  return out;
}

double gaussian_field::point_probe::surface_distance(double t0) const {
  const double gn = norm(gradient);
  return gn > 0 ? std::abs(value - t0) / gn : std::numeric_limits<double>::infinity();
}

double gaussian_field::surface_distance(const vec3& p) const {
  vec3 g;
  const double phi = value_and_gradient(p, g);
  const double gn = norm(g);
  return gn > 0 ? std::abs(phi - t0_) / gn : std::numeric_limits<double>::infinity();
}

bool gaussian_field::project_to_surface(vec3& p, double max_move) const {
  vec3 q = p;
  for (int iteration = 0; iteration < 40; ++iteration) {
    vec3 g;
    const double residual = value_and_gradient(q, g) - t0_;
    const double g2 = squared_norm(g);
    if (g2 == 0) return false;
    if (std::abs(residual) <= 1e-12 * t0_ || std::abs(residual) / std::sqrt(g2) < 1e-10) {
      p = q;
      return true;
    }
    vec3 step = g * (residual / g2);  // Newton along the gradient line
    const double step_length = norm(step);
    if (step_length > 0.5 * max_move) step *= 0.5 * max_move / step_length;  // damped far from S
    q -= step;
    if (distance(q, p) > max_move) return false;
  }
  return false;
}

void gaussian_field::atoms_near_box(const box3& box, std::vector<std::uint32_t>& out) const {
  out.clear();
  const std::int64_t x0 = cell_of(box.lo.x - max_cutoff_), x1 = cell_of(box.hi.x + max_cutoff_);
  const std::int64_t y0 = cell_of(box.lo.y - max_cutoff_), y1 = cell_of(box.hi.y + max_cutoff_);
  const std::int64_t z0 = cell_of(box.lo.z - max_cutoff_), z1 = cell_of(box.hi.z + max_cutoff_);
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) {
      const auto row = rows_.find(row_key(ix, iy));
      if (row == rows_.end()) continue;
      const auto first = cell_z_.begin() + row->second.begin;
      const auto last = cell_z_.begin() + row->second.end;
      for (auto it = std::lower_bound(first, last, z0); it != last && *it <= z1; ++it) {
        const auto k = static_cast<std::uint32_t>(it - cell_z_.begin());
        const atom_data& a = data_[k];
        // Squared distance from the centre to the box; keep atoms whose cutoff sphere reaches it.
        const double dx = std::max({box.lo.x - a.x, 0.0, a.x - box.hi.x});
        const double dy = std::max({box.lo.y - a.y, 0.0, a.y - box.hi.y});
        const double dz = std::max({box.lo.z - a.z, 0.0, a.z - box.hi.z});
        if (dx * dx + dy * dy + dz * dz < a.cutoff2) out.push_back(k);
      }
    }
  }
  std::sort(out.begin(), out.end());
}

}  // namespace tracemesh
