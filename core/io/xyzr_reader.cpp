#include "core/io/xyzr_reader.hpp"

#include <array>
#include <cmath>
#include <string>

#include "core/io/atom_checks.hpp"
#include "core/io/pqr_text.hpp"
#include "core/io/text_lines.hpp"

namespace tracemesh {

namespace {

constexpr std::size_t xyzr_fields = 4;
constexpr std::array<const char*, xyzr_fields> field_names = {"x coordinate", "y coordinate", "z coordinate",
                                                              "radius"};

/// Splits `line` into at most xyzr_fields + 1 whitespace-separated fields; returns how many it found (capped).
std::size_t split_fields(std::string_view line, std::array<std::string_view, xyzr_fields + 1>& out) {
  std::size_t count = 0;
  std::size_t i = 0;
  while (i < line.size() && count < out.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i == line.size()) break;
    const std::size_t begin = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    out[count++] = line.substr(begin, i - begin);
  }
  return count;
}

status parse_line(std::string_view line, std::size_t line_number, const mesh_limits& limits, molecule& mol) {
  std::array<std::string_view, xyzr_fields + 1> fields;
  const std::size_t count = split_fields(line, fields);
  if (count == 0) return status::success();  // blank line
  if (count != xyzr_fields) {
    return detail::line_error(line_number, count > xyzr_fields ? "more than 4 fields; an xyzr line is x y z r"
                                                               : std::to_string(count) +
                                                                     " fields; an xyzr line is x y z r");
  }
  if (mol.atoms.size() == limits.max_atoms) {
    return {errc::limit_exceeded, "line " + std::to_string(line_number) + ": more than " +
                                      std::to_string(limits.max_atoms) + " atoms (limits.max_atoms)"};
  }
  std::array<double, xyzr_fields> values{};
  for (std::size_t k = 0; k < xyzr_fields; ++k) {
    const detail::parsed_number parsed = detail::parse_number(fields[k]);
    if (parsed.error != detail::number_error::none) {
      return detail::line_error(line_number, std::string(field_names[k]) + " '" + detail::quote_bytes(fields[k]) +
                                                 "' is not a finite decimal number");
    }
    values[k] = parsed.value;
  }
  atom new_atom;
  new_atom.center = {values[0], values[1], values[2]};
  new_atom.radius = values[3];
  if (std::string problem = detail::atom_range_problem(new_atom, limits); !problem.empty()) {
    return detail::line_error(line_number, problem);
  }
  detail::add_atom(mol, new_atom);
  return status::success();
}

}  // namespace

result<molecule> parse_xyzr(std::string_view text, const mesh_limits& limits) {
  detail::text_lines lines(text, limits.max_line_bytes, "xyzr");
  molecule mol;
  std::string_view line;
  for (;;) {
    result<bool> more = lines.next(line);
    if (!more) return more.error();
    if (!*more) break;
    if (status parsed = parse_line(line, lines.line_number(), limits, mol); !parsed) return parsed;
  }
  if (status usable = detail::check_something_to_mesh(mol, "xyzr line"); !usable) return usable;
  return mol;
}

}  // namespace tracemesh
