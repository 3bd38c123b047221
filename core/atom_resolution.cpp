#include "core/atom_resolution.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/limits.hpp"

namespace tracemesh {

namespace {

/// Radius of an atom's own surface sphere relative to its radius: √(1 + ln t0 / d), 0 when the atom alone never
/// reaches t0 (t0 ≥ e^{-d}).
double surface_radius_factor(double d, double t0) {
  const double q = 1.0 + std::log(t0) / d;
  return q > 0 ? std::sqrt(q) : 0.0;
}

/// Directions in which the surface's distance from an atom's centre is sampled: the axes and the cube's diagonals.
std::array<vec3, 14> probe_directions() {
  std::array<vec3, 14> out{};
  std::size_t n = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (const double sign : {-1.0, 1.0}) {
      vec3 u{};
      u[axis] = sign;
      out[n++] = u;
    }
  }
  for (const double x : {-1.0, 1.0}) {
    for (const double y : {-1.0, 1.0}) {
      for (const double z : {-1.0, 1.0}) out[n++] = normalized(vec3{x, y, z});
    }
  }
  return out;
}

/// Samples along each probe direction up to `reach` Å (then bisection where one lies outside).
constexpr int reach_samples = 2;

/// When the centre lies inside the surface (φ ≥ t0) and the surface comes within `reach` Å of it along a probe
/// direction: the nearest such distance (Å, by bisection). Nothing otherwise (centre outside, or the surface
/// farther away).
std::optional<double> surface_within(const gaussian_field& field, const vec3& centre, double reach) {
  const double t0 = field.t0();
  if (field.value(centre) < t0) return std::nullopt;
  std::optional<double> nearest;
  for (const vec3& u : probe_directions()) {
    double inside = 0;
    for (int k = 1; k <= reach_samples; ++k) {
      const double s = reach * k / reach_samples;
      if (field.value(centre + u * s) >= t0) {
        inside = s;
        continue;
      }
      double outside = s;
      for (int iteration = 0; iteration < 50; ++iteration) {
        const double mid = 0.5 * (inside + outside);
        (field.value(centre + u * mid) >= t0 ? inside : outside) = mid;
      }
      nearest = std::min(nearest.value_or(outside), outside);
      break;
    }
  }
  return nearest;
}

/// The density whose smallest resolved radius (min_atom_surface_radius_per_edge mesh edges) is `radius`, rounded up
/// to 4 significant digits (the density a message suggests must resolve the atom as printed).
double density_resolving(double radius) {
  const double density =
      2.0 / (std::sqrt(3.0) * std::pow(radius / parameter_ranges::min_atom_surface_radius_per_edge, 2));
  const double unit = std::pow(10.0, std::floor(std::log10(density)) - 3);
  return std::ceil(density / unit) * unit;
}

}  // namespace

double mesh_edge_length(double density) noexcept { return std::sqrt(2.0 / (std::sqrt(3.0) * density)); }

status check_atom_resolution(const molecule& mol, const mesh_params& params, const progress_token& progress) {
  const double edge = mesh_edge_length(params.density);
  const double min_surface_radius = parameter_ranges::min_atom_surface_radius_per_edge * edge;
  const double factor = surface_radius_factor(params.d, params.t0);
  const auto resolvable = [&](const atom& a) { return a.radius * factor >= min_surface_radius; };

  std::vector<std::size_t> small;  // indices of atoms with radius > 0 below the rule
  molecule resolved;
  for (std::size_t i = 0; i < mol.atoms.size(); ++i) {
    const atom& a = mol.atoms[i];
    if (a.radius == 0) continue;
    if (resolvable(a)) {
      resolved.atoms.push_back(a);
    } else {
      small.push_back(i);
    }
  }
  if (small.empty()) return status::success();

  // Buried: the centre lies inside the surface of the resolvable atoms (their field reaches t0 there).
  std::optional<gaussian_field> resolvable_field;
  if (!resolved.atoms.empty()) resolvable_field.emplace(resolved, params.d, params.t0);
  // Otherwise the surface of all the atoms decides: an atom whose centre lies outside it makes no feature of its
  // own (with t0 ≥ e^{-d} no atom alone reaches t0), and one whose centre lies at least the smallest radius inside
  // it sits in a feature the mesh resolves. Near t0 = e^{-d} every atom's own sphere is tiny while the molecule's
  // surface is not (gly at d = −1, t0 = 2.7 was refused whole before, naming its first atom).
  std::vector<std::size_t> exposed;
  for (const std::size_t i : small) {
    if (!(resolvable_field && resolvable_field->value(mol.atoms[i].center) >= params.t0)) exposed.push_back(i);
  }
  if (exposed.empty()) return status::success();
  const gaussian_field field(mol, params.d, params.t0);
  std::vector<std::optional<double>> nearest(exposed.size());  // in parallel, then read in atom order
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, exposed.size(), 64), [&](const auto& range) {
    if (progress.cancelled()) return;
    for (std::size_t n = range.begin(); n != range.end(); ++n) {
      nearest[n] = surface_within(field, mol.atoms[exposed[n]].center, min_surface_radius);
    }
  });
  if (progress.cancelled()) return status{errc::cancelled, "meshing was cancelled"};
  std::size_t first_refused = 0, refused = 0;
  double nearest_of_first = 0, largest_needed_density = 0;
  for (std::size_t n = 0; n < exposed.size(); ++n) {
    if (!nearest[n]) continue;
    if (refused++ == 0) first_refused = exposed[n], nearest_of_first = *nearest[n];
    largest_needed_density = std::max(largest_needed_density, density_resolving(*nearest[n]));
  }
  if (refused == 0) return status::success();
  const atom& a = mol.atoms[first_refused];
  std::ostringstream why;
  why << "atom " << first_refused + 1 << " (radius " << a.radius << " \u00c5) is too small to be meshed at density "
      << params.density << ": the surface passes " << nearest_of_first << " \u00c5 from its centre, and must keep at least "
      << min_surface_radius << " \u00c5 (" << parameter_ranges::min_atom_surface_radius_per_edge << " mesh edge of "
      << edge << " \u00c5 at d = " << params.d << ", t0 = " << params.t0 << ")";
  const std::string which = refused == 1 ? "" : " (every one of the " + std::to_string(refused) + " atoms too small)";
  // Only a density the service accepts is worth suggesting.
  if (largest_needed_density <= parameter_ranges::max_density) {
    why << "; raise the density to at least " << largest_needed_density << which << ",";
  } else {
    why << "; no accepted density resolves it" << which << " (it would need " << largest_needed_density
        << ", the maximum is " << parameter_ranges::max_density << "),";
  }
  why << " or give the atom radius 0 to leave it out";
  return status{errc::unresolvable_input, why.str()};
}

}  // namespace tracemesh
