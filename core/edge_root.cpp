#include "core/edge_root.hpp"

#include <algorithm>
#include <cmath>

#include "core/lattice_sampler.hpp"

namespace tracemesh {
namespace {

/// One atom's kernel along an edge a + t·Δ: |a + tΔ − c|² = A + 2tB + t²C.
struct edge_term {
  double a, b;     // A and B
  double d_inv_r2; // d / r²
  double cutoff2;
};

/// φ along one edge as a sum of 1-D Gaussians in t (the kernel is separable along any line).
class edge_function {
 public:
  edge_function(const gaussian_field& field, const vec3& origin, const vec3& delta,
                std::span<const std::uint32_t> cube_atoms)
      : c_(squared_norm(delta)), scale_(std::exp(-field.d())) {
    terms_.reserve(cube_atoms.size());
    for (const std::uint32_t k : cube_atoms) {
      const auto& at = field.atom_at(k);
      const vec3 offset = origin - vec3{at.x, at.y, at.z};
      terms_.push_back({squared_norm(offset), dot(offset, delta), field.d() * at.inv_r2, at.cutoff2});
    }
  }

  /// φ(t) and dφ/dt, with each atom cut off exactly as gaussian_field does.
  double value(double t, double& derivative) const {
    double phi = 0, slope = 0;
    for (const edge_term& term : terms_) {
      const double r2 = term.a + t * (2 * term.b + t * c_);
      if (r2 >= term.cutoff2) continue;
      const double k = scale_ * std::exp(term.d_inv_r2 * r2);
      phi += k;
      slope += k * term.d_inv_r2 * 2 * (term.b + t * c_);
    }
    derivative = slope;
    return phi;
  }

 private:
  double c_, scale_;
  std::vector<edge_term> terms_;
};

/// Root of φ = t0 on [0, 1] where φ(inside_t) ≥ t0 > φ(outside_t); `guess` from the sampled values.
double solve(const edge_function& f, double t0, double inside_t, double outside_t, double guess) {
  double t = guess;
  for (int iteration = 0; iteration < 60; ++iteration) {
    double slope = 0;
    const double residual = f.value(t, slope) - t0;
    if (residual == 0) break;
    (residual > 0 ? inside_t : outside_t) = t;
    if (std::abs(outside_t - inside_t) < 1e-12) break;
    double next = slope != 0 ? t - residual / slope : 0.5 * (inside_t + outside_t);
    if (!(next > std::min(inside_t, outside_t) && next < std::max(inside_t, outside_t))) {
      next = 0.5 * (inside_t + outside_t);  // Newton left the bracket: bisect
    }
    const bool converged = std::abs(next - t) < 1e-12;
    t = next;
    if (converged) break;
  }
  return std::clamp(t, edge_root_margin, 1 - edge_root_margin);
}

}  // namespace

void solve_block_roots(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                       std::span<const std::uint32_t> atoms, std::span<const double> values,
                       std::vector<edge_vertex>& out) {
  constexpr int n = block_points;
  const double t0 = field.t0();
  const double h = lat.spacing();
  const auto value_at = [&](int x, int y, int z) { return values[static_cast<std::size_t>((z * n + y) * n + x)]; };
  std::vector<std::uint32_t> cube_atoms;
  for (int z = 0; z < lattice::block_cells; ++z) {
    for (int y = 0; y < lattice::block_cells; ++y) {
      for (int x = 0; x < lattice::block_cells; ++x) {
        const double v0 = value_at(x, y, z);
        bool gathered = false;
        const lattice_index p{block.i * lattice::block_cells + x, block.j * lattice::block_cells + y,
                              block.k * lattice::block_cells + z};
        const vec3 origin = lat.point(p);
        for (int direction = 0; direction < 7; ++direction) {
          const auto& dir = edge_directions[direction];
          const double v1 = value_at(x + dir[0], y + dir[1], z + dir[2]);
          if ((v0 >= t0) == (v1 >= t0)) continue;
          if (!gathered) {
            // Atoms whose cutoff reaches this cube: every edge the cube owns lies inside it.
            const box3 cube{origin, origin + vec3{h, h, h}};
            cube_atoms.clear();
            for (const std::uint32_t k : atoms) {
              const auto& a = field.atom_at(k);
              const double dx = std::max({cube.lo.x - a.x, 0.0, a.x - cube.hi.x});
              const double dy = std::max({cube.lo.y - a.y, 0.0, a.y - cube.hi.y});
              const double dz = std::max({cube.lo.z - a.z, 0.0, a.z - cube.hi.z});
              if (dx * dx + dy * dy + dz * dz < a.cutoff2) cube_atoms.push_back(k);
            }
            gathered = true;
          }
          const vec3 delta{dir[0] * h, dir[1] * h, dir[2] * h};
          const edge_function f(field, origin, delta, cube_atoms);
          const double guess = (v0 - t0) / (v0 - v1);  // linear interpolation of the sampled values
          const double t = v0 >= t0 ? solve(f, t0, 0.0, 1.0, guess) : solve(f, t0, 1.0, 0.0, guess);
          out.push_back({lat.edge_key(p, direction), origin + delta * t});
        }
      }
    }
  }
}

}  // namespace tracemesh
