#include "core/lattice/lattice.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace tracemesh {
namespace {

std::string format_number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

result<lattice> make_lattice(const gaussian_field& field, double spacing, const mesh_limits& limits) {
  const box3& bounds = field.atom_bounds();
  const double margin = field.max_cutoff() + 2 * spacing * lattice::block_cells;
  const auto index_floor = [&](double v) {
    const auto cells = static_cast<std::int64_t>(std::floor(v / (spacing * lattice::block_cells)));
    return cells * lattice::block_cells;
  };
  lattice_index origin{index_floor(bounds.lo.x - margin), index_floor(bounds.lo.y - margin),
                       index_floor(bounds.lo.z - margin)};
  for (int axis = 0; axis < 3; ++axis) {
    const double extent = bounds.hi[axis] - bounds.lo[axis] + 2 * margin;
    if (extent / spacing > static_cast<double>(limits.max_lattice_extent)) {
      return status{errc::limit_exceeded, "molecule extent " + format_number(extent) + " Å needs more than " +
                                              std::to_string(limits.max_lattice_extent) +
                                              " lattice points per axis at this density"};
    }
  }
  return lattice(spacing, origin);
}

}  // namespace tracemesh
