#pragma once
/// @file vdw_radii.hpp
/// Per-element van der Waals radii for inputs without radii (PDB, mmCIF). Two published sets:
///
/// - `bondi` (the default): A. Bondi, "van der Waals Volumes and Radii", J. Phys. Chem. 68, 441–451 (1964),
///   Table I — the radii most molecular surface programs use (MSMS, NanoShaper, PyMOL's defaults). 38 elements;
///   no Ca, Fe, Mn, Co (add them with a PQR if needed).
/// - `mantina`: M. Mantina, A. C. Chamberlin, R. Valero, C. J. Cramer, D. G. Truhlar, "Consistent van der Waals
///   Radii for the Whole Main Group", J. Phys. Chem. A 113, 5806–5812 (2009), Table 12: Bondi's values kept
///   where they hold, H 1.10 Å (from its calculations), and every main-group element added (Be, B, Al, Ca, Ge,
///   Rb, Sr, Sb, Cs, Ba, Bi, ...). No transition metals.
///
/// Deuterium takes hydrogen's radius. Values are in Å, exactly as printed in the papers.

#include <optional>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh {

enum class radii_set { bondi, mantina };

/// "bondi" or "mantina" (lower case). Error: errc::invalid_argument naming the accepted values.
result<radii_set> parse_radii_set(std::string_view name);
/// The name parse_radii_set reads.
std::string_view radii_set_name(radii_set set) noexcept;

/// Radius of the element with this symbol ("C", "Cl", case-insensitive: "CL" too) in `set`, or nullopt when
/// the set has none for it (or the symbol is not an element).
std::optional<double> vdw_radius(radii_set set, std::string_view element_symbol) noexcept;

}  // namespace tracemesh
