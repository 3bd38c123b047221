#include "core/atom_resolution.hpp"

#include <cmath>
#include <optional>
#include <sstream>
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

}  // namespace

double mesh_edge_length(double density) noexcept { return std::sqrt(2.0 / (std::sqrt(3.0) * density)); }

status check_atom_resolution(const molecule& mol, const mesh_params& params) {
  const double edge = mesh_edge_length(params.density);
  const double min_surface_radius = parameter_ranges::min_atom_surface_radius_per_edge * edge;
  const double factor = surface_radius_factor(params.d, params.t0);
  // With t0 ≥ e^{-d} no atom has a surface sphere of its own: every piece of surface is made by a group of atoms,
  // and the rule, which is about one atom's sphere, does not apply. A surface the lines cannot see is reported as
  // such by the mesher (run_pipeline: unresolvable at this density, or empty).
  if (factor == 0) return status::success();
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
  std::optional<gaussian_field> field;
  if (!resolved.atoms.empty()) field.emplace(resolved, params.d, params.t0);
  for (const std::size_t i : small) {
    if (field && field->probe(mol.atoms[i].center).value >= params.t0) continue;
    const atom& a = mol.atoms[i];
    std::ostringstream why;
    why << "atom " << i + 1 << " (radius " << a.radius << " \u00c5) is too small to be meshed at density "
        << params.density << ": its surface sphere must have a radius of at least " << min_surface_radius
        << " \u00c5 (" << parameter_ranges::min_atom_surface_radius_per_edge << " mesh edge of " << edge
        << " \u00c5 at d = " << params.d << ", t0 = " << params.t0 << ")";
    const double needed_density =
        2.0 / (std::sqrt(3.0) * std::pow(a.radius * factor / parameter_ranges::min_atom_surface_radius_per_edge, 2));
    // Only a density the service accepts is worth suggesting.
    if (needed_density <= parameter_ranges::max_density) {
      why << "; raise the density to at least " << needed_density << ",";
    } else {
      why << "; no accepted density resolves it (it would need " << needed_density << ", the maximum is "
          << parameter_ranges::max_density << "),";
    }
    why << " or give the atom radius 0 to leave it out";
    return status{errc::unresolvable_input, why.str()};
  }
  return status::success();
}

}  // namespace tracemesh
