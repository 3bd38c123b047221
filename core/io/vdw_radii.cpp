#include "core/io/vdw_radii.hpp"

#include <array>
#include <string>

#include "core/io/pqr_text.hpp"

namespace tracemesh {

namespace {

struct element_radius {
  std::string_view symbol;
  double radius;  // Å
};

// Bondi 1964, Table I (the "van der Waals radii" column).
constexpr std::array<element_radius, 38> bondi_radii = {{
    {"H", 1.20},  {"He", 1.40}, {"Li", 1.82}, {"C", 1.70},  {"N", 1.55},  {"O", 1.52},  {"F", 1.47},
    {"Ne", 1.54}, {"Na", 2.27}, {"Mg", 1.73}, {"Si", 2.10}, {"P", 1.80},  {"S", 1.80},  {"Cl", 1.75},
    {"Ar", 1.88}, {"K", 2.75},  {"Ni", 1.63}, {"Cu", 1.40}, {"Zn", 1.39}, {"Ga", 1.87}, {"As", 1.85},
    {"Se", 1.90}, {"Br", 1.85}, {"Kr", 2.02}, {"Pd", 1.63}, {"Ag", 1.72}, {"Cd", 1.58}, {"In", 1.93},
    {"Sn", 2.17}, {"Te", 2.06}, {"I", 1.98},  {"Xe", 2.16}, {"Pt", 1.75}, {"Au", 1.66}, {"Hg", 1.55},
    {"Tl", 1.96}, {"Pb", 2.02}, {"U", 1.86},
}};

// Mantina et al. 2009, Table 12 (main group, periods 1–7).
constexpr std::array<element_radius, 44> mantina_radii = {{
    {"H", 1.10},  {"He", 1.40}, {"Li", 1.81}, {"Be", 1.53}, {"B", 1.92},  {"C", 1.70},  {"N", 1.55},
    {"O", 1.52},  {"F", 1.47},  {"Ne", 1.54}, {"Na", 2.27}, {"Mg", 1.73}, {"Al", 1.84}, {"Si", 2.10},
    {"P", 1.80},  {"S", 1.80},  {"Cl", 1.75}, {"Ar", 1.88}, {"K", 2.75},  {"Ca", 2.31}, {"Ga", 1.87},
    {"Ge", 2.11}, {"As", 1.85}, {"Se", 1.90}, {"Br", 1.83}, {"Kr", 2.02}, {"Rb", 3.03}, {"Sr", 2.49},
    {"In", 1.93}, {"Sn", 2.17}, {"Sb", 2.06}, {"Te", 2.06}, {"I", 1.98},  {"Xe", 2.16}, {"Cs", 3.43},
    {"Ba", 2.68}, {"Tl", 1.96}, {"Pb", 2.02}, {"Bi", 2.07}, {"Po", 1.97}, {"At", 2.02}, {"Rn", 2.20},
    {"Fr", 3.48}, {"Ra", 2.83},
}};

char to_lower(char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }

bool same_symbol(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (to_lower(a[i]) != to_lower(b[i])) return false;
  }
  return true;
}

template <std::size_t N>
std::optional<double> find_radius(const std::array<element_radius, N>& table, std::string_view symbol) {
  for (const element_radius& entry : table) {
    if (same_symbol(entry.symbol, symbol)) return entry.radius;
  }
  return std::nullopt;
}

}  // namespace

result<radii_set> parse_radii_set(std::string_view name) {
  if (name == "bondi") return radii_set::bondi;
  if (name == "mantina") return radii_set::mantina;
  return status{errc::invalid_argument, "radii must be bondi or mantina, not '" +
                                            detail::quote_bytes(name) + "'"};
}

std::string_view radii_set_name(radii_set set) noexcept {
  return set == radii_set::mantina ? "mantina" : "bondi";
}

std::optional<double> vdw_radius(radii_set set, std::string_view element_symbol) noexcept {
  if (same_symbol(element_symbol, "D")) element_symbol = "H";  // deuterium
  return set == radii_set::mantina ? find_radius(mantina_radii, element_symbol)
                                   : find_radius(bondi_radii, element_symbol);
}

}  // namespace tracemesh
