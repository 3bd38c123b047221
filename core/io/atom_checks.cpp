#include "core/io/atom_checks.hpp"

#include <cmath>

#include "core/io/pqr_text.hpp"

namespace tracemesh::detail {

std::string atom_range_problem(const atom& a, const mesh_limits& limits) {
  const char* const names[] = {"x coordinate", "y coordinate", "z coordinate"};
  const double coordinates[] = {a.center.x, a.center.y, a.center.z};
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(coordinates[k])) return std::string(names[k]) + " is not a finite number";
    if (std::fabs(coordinates[k]) > limits.max_abs_coordinate) {
      return std::string(names[k]) + " " + format_number(coordinates[k]) + " is beyond +-" +
             format_number(limits.max_abs_coordinate) + " Angstrom (limits.max_abs_coordinate)";
    }
  }
  if (!std::isfinite(a.radius)) return "radius is not a finite number";
  if (std::signbit(a.radius)) return "radius " + format_number(a.radius) + " is negative";
  if (a.radius > limits.max_radius) {
    return "radius " + format_number(a.radius) + " is larger than " + format_number(limits.max_radius) +
           " Angstrom (limits.max_radius)";
  }
  return {};
}

void add_atom(molecule& mol, const atom& a) {
  if (a.radius == 0) ++mol.zero_radius_atoms;
  mol.atoms.push_back(a);
}

status check_something_to_mesh(const molecule& mol, std::string_view records) {
  if (mol.atoms.empty()) {
    return {errc::nothing_to_mesh, "no atoms with radius > 0: the input has no " + std::string(records)};
  }
  if (mol.zero_radius_atoms == mol.atoms.size()) {
    return {errc::nothing_to_mesh,
            "no atoms with radius > 0: all " + std::to_string(mol.atoms.size()) + " atoms have radius 0"};
  }
  return status::success();
}

}  // namespace tracemesh::detail
