#include "core/io/input_format.hpp"

#include <string>
#include <utility>

#include "core/io/pqr_text.hpp"

namespace tracemesh {

namespace {

bool starts_with(std::string_view text, std::string_view prefix) { return text.substr(0, prefix.size()) == prefix; }
bool is_blank(std::string_view line) { return line.find_first_not_of(" \t") == std::string_view::npos; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// The same atom-record rule as the PQR reader: "ATOM" or "HETATM", then a space, tab, digit or the end.
bool is_atom_record(std::string_view line) {
  for (const std::string_view name : {std::string_view("ATOM"), std::string_view("HETATM")}) {
    if (!starts_with(line, name)) continue;
    if (line.size() == name.size()) return true;
    const char next = line[name.size()];
    if (next == ' ' || next == '\t' || is_digit(next)) return true;
  }
  return false;
}

/// The whitespace-separated fields of `line`, when there are exactly `count` and all are numbers.
bool is_numbers(std::string_view line, std::size_t count) {
  std::size_t found = 0;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i == line.size()) break;
    const std::size_t begin = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (++found > count) return false;
    if (detail::parse_number(line.substr(begin, i - begin)).error != detail::number_error::none) return false;
  }
  return found == count;
}

/// True when the atom record ends with five numbers (x y z charge radius), fused fields split as PQR does.
bool ends_with_five_numbers(std::string_view record) {
  const std::size_t name_length = starts_with(record, "HETATM") ? 6 : 4;
  const detail::atom_record_fields split = detail::split_atom_record(record.substr(name_length));
  if (split.number_count < detail::record_number_count) return false;
  for (const std::string_view number : split.numbers) {
    if (detail::parse_number(number).error != detail::number_error::none) return false;
  }
  return true;
}

std::string_view strip_cr(std::string_view line) {
  while (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

}  // namespace

std::string_view input_format_name(input_format format) noexcept {
  switch (format) {
    case input_format::pqr: return "pqr";
    case input_format::pdb: return "pdb";
    case input_format::mmcif: return "mmcif";
    case input_format::xyzr: return "xyzr";
  }
  return "pqr";
}

input_format detect_input_format(std::string_view text, std::size_t max_line_bytes) {
  if (starts_with(text, "\xEF\xBB\xBF")) text.remove_prefix(3);
  bool first_meaningful = true;  // no non-blank, non-comment line seen yet
  bool first_non_blank = true;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find_first_of("\r\n", begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = strip_cr(text.substr(begin, std::min(end - begin, max_line_bytes)));
    begin = end + 1;
    if (is_blank(line)) continue;
    if (first_non_blank && is_numbers(line, 4)) return input_format::xyzr;
    first_non_blank = false;
    if (line.front() == '#') continue;
    if (first_meaningful && starts_with(line, "data_")) return input_format::mmcif;
    first_meaningful = false;
    if (starts_with(line, "HEADER") || starts_with(line, "CRYST1")) return input_format::pdb;
    if (is_atom_record(line)) return ends_with_five_numbers(line) ? input_format::pqr : input_format::pdb;
  }
  return input_format::pqr;
}

namespace {

result<bool> parse_keep_or_drop(std::string_view option, std::string_view value) {
  if (value == "keep") return true;
  if (value == "drop") return false;
  return status{errc::invalid_argument,
                std::string(option) + " must be keep or drop, not '" + detail::quote_bytes(value) + "'"};
}

}  // namespace

result<structure_options> parse_structure_options(
    const std::function<std::optional<std::string>(std::string_view name)>& lookup) {
  structure_options options;
  if (const std::optional<std::string> radii = lookup("radii")) {
    result<radii_set> set = parse_radii_set(*radii);
    if (!set.ok()) return set.error();
    options.radii = *set;
  }
  const std::pair<std::string_view, bool*> flags[] = {{"hydrogens", &options.keep_hydrogens},
                                                      {"waters", &options.keep_waters},
                                                      {"ligands", &options.keep_ligands}};
  for (const auto& [name, keep] : flags) {
    if (const std::optional<std::string> value = lookup(name)) {
      result<bool> parsed = parse_keep_or_drop(name, *value);
      if (!parsed.ok()) return parsed.error();
      *keep = *parsed;
    }
  }
  return options;
}

}  // namespace tracemesh
