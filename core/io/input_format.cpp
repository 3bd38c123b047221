#include "core/io/input_format.hpp"

#include <algorithm>
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

/// Index of the first CR or LF at or after `begin`, or text.size() (a loop: find_first_of("\r\n") calls memchr
/// on its two-byte set for every byte of the text).
std::size_t line_break_at_or_after(std::string_view text, std::size_t begin) {
  std::size_t i = begin;
  while (i < text.size() && text[i] != '\n' && text[i] != '\r') ++i;
  return i;
}

std::string_view strip_cr(std::string_view line) {
  while (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

/// The number of whitespace-separated fields of `line`, counting at most `cap + 1`.
std::size_t field_count(std::string_view line, std::size_t cap) {
  std::size_t found = 0;
  std::size_t i = 0;
  while (i < line.size() && found <= cap) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i == line.size()) break;
    ++found;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
  }
  return found;
}

/// True when the first non-blank byte of `line` can start a decimal number.
bool starts_as_number(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t");
  if (first == std::string_view::npos) return false;
  const char c = line[first];
  return is_digit(c) || c == '-' || c == '+' || c == '.';
}

char to_lower(char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }

bool ends_with_ignoring_case(std::string_view text, std::string_view suffix) {
  if (text.size() < suffix.size()) return false;
  const std::string_view tail = text.substr(text.size() - suffix.size());
  for (std::size_t i = 0; i < suffix.size(); ++i) {
    if (to_lower(tail[i]) != suffix[i]) return false;
  }
  return true;
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

result<input_format> parse_input_format(std::string_view name) {
  for (const input_format format : {input_format::pqr, input_format::pdb, input_format::mmcif, input_format::xyzr}) {
    if (name == input_format_name(format)) return format;
  }
  return status{errc::invalid_argument,
                "format_in must be pqr, pdb, mmcif or xyzr, not '" + detail::quote_bytes(name) + "'"};
}

std::optional<input_format> input_format_of_file_name(std::string_view file_name) {
  if (ends_with_ignoring_case(file_name, ".gz")) file_name.remove_suffix(3);
  const std::pair<std::string_view, input_format> extensions[] = {
      {".pqr", input_format::pqr},     {".pdb", input_format::pdb},     {".ent", input_format::pdb},
      {".cif", input_format::mmcif},   {".mmcif", input_format::mmcif}, {".xyzr", input_format::xyzr}};
  for (const auto& [extension, format] : extensions) {
    if (ends_with_ignoring_case(file_name, extension)) return format;
  }
  return std::nullopt;
}

structure_options declared_by_file_name(std::string_view file_name, structure_options options) {
  if (options.format) return options;
  if (const std::optional<input_format> format = input_format_of_file_name(file_name)) {
    options.format = declared_format{*format, "the file name '" + std::string(file_name) + "'"};
  }
  return options;
}

format_evidence examine_input_format(std::string_view text, std::size_t max_line_bytes, record_evidence records) {
  if (starts_with(text, "\xEF\xBB\xBF")) text.remove_prefix(3);
  format_evidence evidence;
  bool first_meaningful = true;  // no non-blank, non-comment line seen yet
  bool first_non_blank = true;
  std::size_t begin = 0;
  while (begin < text.size()) {
    const std::size_t end = line_break_at_or_after(text, begin);
    const std::string_view line = strip_cr(text.substr(begin, std::min(end - begin, max_line_bytes)));
    begin = end + 1;
    if (is_blank(line)) continue;
    if (first_non_blank) {
      evidence.xyzr_like_first = starts_as_number(line) && field_count(line, 4) == 4;
      evidence.xyzr_first_line = is_numbers(line, 4);
      if (evidence.xyzr_first_line) return evidence;
      first_non_blank = false;
    }
    if (line.front() == '#') continue;
    if (first_meaningful && starts_with(line, "data_")) {
      evidence.mmcif_header = true;
      return evidence;
    }
    first_meaningful = false;
    const bool before_atoms = evidence.atom_records == 0;
    if (before_atoms && (starts_with(line, "HEADER") || starts_with(line, "CRYST1"))) {
      evidence.pdb_header = true;
      return evidence;
    }
    if (!is_atom_record(line)) continue;
    ++evidence.atom_records;
    if (records == record_evidence::classified) {
      ++(ends_with_five_numbers(line) ? evidence.pqr_records : evidence.other_records);
    }
  }
  return evidence;
}

input_format detected_format(const format_evidence& evidence) noexcept {
  if (evidence.mmcif_header) return input_format::mmcif;
  if (evidence.xyzr_first_line) return input_format::xyzr;
  if (evidence.pdb_header) return input_format::pdb;
  if (evidence.atom_records == 0) return evidence.xyzr_like_first ? input_format::xyzr : input_format::pqr;
  return evidence.pqr_records >= evidence.other_records ? input_format::pqr : input_format::pdb;
}

input_format detect_input_format(std::string_view text, std::size_t max_line_bytes) {
  return detected_format(examine_input_format(text, max_line_bytes));
}

status check_declared_format(const declared_format& declared, const format_evidence& evidence) {
  const std::string declaration = declared.declared_by + " declares " + std::string(input_format_name(declared.format));
  const auto contradiction = [&](const std::string& content) {
    return status{errc::invalid_input, declaration + ", but " + content};
  };
  const std::size_t records = evidence.atom_records;
  if (evidence.mmcif_header != (declared.format == input_format::mmcif)) {
    return contradiction(evidence.mmcif_header ? "the text is mmCIF (it starts with a data_ block)"
                                               : "the text is not mmCIF (it does not start with a data_ block)");
  }
  switch (declared.format) {
    case input_format::mmcif: break;
    case input_format::xyzr:
      if (records > 0) return contradiction("the text has ATOM/HETATM records (PQR or PDB), not x y z r lines");
      break;
    case input_format::pqr:
    case input_format::pdb:
      if (records == 0 && evidence.xyzr_like_first) {
        return contradiction("the text is xyzr (x y z r lines, no ATOM/HETATM record)");
      }
      break;
  }
  return status::success();
}

namespace {

result<bool> parse_keep_or_drop(std::string_view option, std::string_view value) {
  if (value == "keep") return true;
  if (value == "drop") return false;
  return status{errc::invalid_argument,
                std::string(option) + " must be keep or drop, not '" + detail::quote_bytes(value) + "'"};
}

bool is_assembly_id_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || is_digit(c) || c == '_' || c == '-' || c == '.';
}

result<std::string> parse_assembly(std::string_view value) {
  const bool valid = !value.empty() && value.size() <= max_assembly_id_chars &&
                     std::all_of(value.begin(), value.end(), is_assembly_id_char);
  if (valid) return std::string(value);
  return status{errc::invalid_argument,
                "assembly must be asu or an assembly id of 1 to " + std::to_string(max_assembly_id_chars) +
                    " letters, digits, '_', '-' or '.', not '" + detail::quote_bytes(value, max_assembly_id_chars) +
                    "'"};
}

}  // namespace

result<structure_options> parse_structure_options(
    const std::function<std::optional<std::string>(std::string_view name)>& lookup) {
  structure_options options;
  if (const std::optional<std::string> format = lookup("format_in")) {
    result<input_format> parsed = parse_input_format(*format);
    if (!parsed.ok()) return parsed.error();
    options.format = declared_format{*parsed, "format_in=" + *format};
  }
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
  if (const std::optional<std::string> assembly = lookup("assembly")) {
    result<std::string> parsed = parse_assembly(*assembly);
    if (!parsed.ok()) return parsed.error();
    options.assembly = std::move(*parsed);
  }
  return options;
}

std::string_view radii_source(input_format format, const structure_options& options) noexcept {
  switch (format) {
    case input_format::pqr:
    case input_format::xyzr: return "file";
    case input_format::pdb:
    case input_format::mmcif: break;
  }
  return radii_set_name(options.radii);
}

}  // namespace tracemesh
