#include "core/io/pqr_reader.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <system_error>
#include <vector>

#include "core/io/pqr_gzip.hpp"
#include "core/io/pqr_text.hpp"
#include "core/io/text_lines.hpp"

namespace tracemesh {

namespace {

using detail::format_number;
using detail::line_error;
using detail::quote_bytes;

constexpr std::array<const char*, detail::record_number_count> record_number_names = {
    "x coordinate", "y coordinate", "z coordinate", "charge", "radius"};
enum record_number_index : std::size_t { x_index, y_index, z_index, charge_index, radius_index };
/// Whitespace-separated fields of an atom record, record name included, in the two PQR layouts.
constexpr std::size_t pqr_fields_without_chain = 10;
constexpr std::size_t pqr_fields_with_chain = 11;
constexpr const char* pqr_layouts = "10 fields (ATOM serial name resName resSeq x y z charge radius) or 11 (a chain id "
                                    "before resSeq)";
/// Bytes of PQR text per atom line, at least; only sizes the first allocation of the atom array.
constexpr std::size_t min_bytes_per_atom_line = 64;
/// Line numbers of unreadable atom records an error lists; it counts the others.
constexpr std::size_t max_listed_bad_lines = 5;
/// A reader's error is one line of at most this many bytes; the first bad record's message is cut to make room
/// for the list of the others.
constexpr std::size_t max_error_message_bytes = 400;

bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// Length of the record name ("ATOM" or "HETATM") when `line` is an atom record, else 0.
std::size_t atom_record_name_length(std::string_view line) {
  for (const std::string_view name : {std::string_view("ATOM"), std::string_view("HETATM")}) {
    if (line.substr(0, name.size()) != name) continue;
    if (line.size() == name.size()) return name.size();
    const char next = line[name.size()];
    if (next == ' ' || next == '\t' || is_digit(next)) return name.size();
  }
  return 0;
}

/// A residue number: an optional '-', digits and an optional insertion code letter ("52", "-3", "52A"); with
/// `fused_chain_id`, also a one-character chain id in front ("A1000", as fixed PDB columns print it).
bool is_residue_number(std::string_view field, bool fused_chain_id) {
  const auto is_letter = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); };
  if (fused_chain_id && field.size() > 1 && !is_digit(field[0]) && field[0] != '-') field.remove_prefix(1);
  if (!field.empty() && is_letter(field.back())) field.remove_suffix(1);
  if (!field.empty() && field.front() == '-') field.remove_prefix(1);
  return !field.empty() && std::all_of(field.begin(), field.end(), is_digit);
}


/// Streams over PQR text line by line, appending atoms to a molecule. An atom record that cannot be read is
/// remembered and the parse goes on, so that the error names every such line (the first few and their count):
/// a client learns at once whether one line or the whole file is wrong. Errors of the text itself (binary bytes,
/// an overlong line) and the atom limit stop at once.
class pqr_parser {
 public:
  explicit pqr_parser(const mesh_limits& limits) : limits_(limits) {}

  result<molecule> parse(std::string_view text) {
    detail::text_lines lines(text, limits_.max_line_bytes, "PQR");
    molecule_.atoms.reserve(std::min(limits_.max_atoms, lines.size() / min_bytes_per_atom_line + 1));
    std::string_view line;
    for (;;) {
      result<bool> more = lines.next(line);
      if (!more) return more.error();
      if (!*more) break;
      line_number_ = lines.line_number();
      if (status parsed = parse_line(line); !parsed) return parsed;
    }
    return finish();
  }

 private:
  status parse_line(std::string_view line) {
    const std::size_t name_length = atom_record_name_length(line);
    if (name_length == 0) return status::success();  // REMARK, TER, END, MODEL, blank...
    if (records_ == limits_.max_atoms) {
      return {errc::limit_exceeded, "line " + std::to_string(line_number_) + ": more than " +
                                        std::to_string(limits_.max_atoms) + " atoms (limits.max_atoms)"};
    }
    ++records_;
    status read = parse_atom_record(line.substr(0, name_length), line.substr(name_length));
    if (!read) remember_bad_record(std::move(read));
    return status::success();
  }

  void remember_bad_record(status error) {
    if (bad_lines_.empty()) first_bad_record_ = std::move(error);
    if (bad_lines_.size() < max_listed_bad_lines) bad_lines_.push_back(line_number_);
    ++bad_records_;
  }

  /// The first unreadable record's message and, when there are more, how many and where:
  /// "line 1: radius '*****' ...; 3 of 120 atom records cannot be read as PQR (lines 1, 7, 9)".
  status bad_records_error() const {
    if (bad_records_ == 1) return first_bad_record_;
    std::string lines;
    for (const std::size_t line : bad_lines_) lines += (lines.empty() ? "" : ", ") + std::to_string(line);
    if (bad_records_ > bad_lines_.size()) lines += ", ...";
    const std::string summary = "; " + std::to_string(bad_records_) + " of " + std::to_string(records_) +
                                " atom records cannot be read as PQR (lines " + lines + ")";
    std::string first = first_bad_record_.message();
    if (first.size() + summary.size() > max_error_message_bytes) {
      first = first.substr(0, max_error_message_bytes - summary.size() - 3) + "...";
    }
    return {first_bad_record_.code(), first + summary};
  }

  status parse_atom_record(std::string_view record_name, std::string_view fields) {
    const detail::atom_record_fields split = detail::split_atom_record(fields);
    // Syntax of the numbers first (the most precise message for a fused or mistyped field), then the layout,
    // and the ranges only once the numbers are known to be in their columns.
    std::array<double, detail::record_number_count> values{};
    if (split.number_count == detail::record_number_count) {
      for (std::size_t k = 0; k < split.numbers.size(); ++k) {
        if (status read = read_number(k, split.numbers[k], values[k]); !read) return read;
      }
    }
    if (status counted = check_field_layout(record_name, split); !counted) return counted;
    if (status checked = check_ranges(split.numbers, values); !checked) return checked;
    add_atom(values);
    return status::success();
  }

  /// The two PQR layouts (APBS, pdb2pqr): 10 fields without a chain id, 11 with one. A missing or extra column
  /// changes the count, or, when a chain id hides it, puts something other than a residue number before x.
  status check_field_layout(std::string_view record_name, const detail::atom_record_fields& split) const {
    const std::size_t count = 1 + split.leading_count + split.number_count;  // 1: the record name
    if (count != pqr_fields_without_chain && count != pqr_fields_with_chain) {
      return line_error(line_number_, std::string(record_name) + " record has " + std::to_string(count) +
                                          " fields; a PQR atom record has " + pqr_layouts);
    }
    const bool chain_may_touch = count == pqr_fields_without_chain;  // fixed columns: "A1000"
    if (!is_residue_number(split.residue_field, chain_may_touch)) {
      return line_error(line_number_, "residue number '" + quote_bytes(split.residue_field) +
                                          "' is not an integer: a column is missing or extra; a PQR atom record has " +
                                          pqr_layouts);
    }
    return status::success();
  }

  status read_number(std::size_t index, std::string_view text, double& value) const {
    const detail::parsed_number parsed = detail::parse_number(text);
    value = parsed.value;
    if (parsed.error == detail::number_error::none) return status::success();
    return line_error(line_number_, std::string(record_number_names[index]) + " '" + quote_bytes(text) + "' " +
                                        describe(parsed.error));
  }

  static const char* describe(detail::number_error error) {
    switch (error) {
      case detail::number_error::none: return "is a number";
      case detail::number_error::not_a_number: return "is not a decimal number (records end with x y z charge radius)";
      case detail::number_error::out_of_range: return "is out of the range of a double";
      case detail::number_error::not_finite: return "is not finite";
    }
    return "is not a number";
  }

  status check_ranges(const detail::record_numbers_text& texts,
                      const std::array<double, detail::record_number_count>& values) const {
    for (const std::size_t k : {x_index, y_index, z_index}) {
      if (std::fabs(values[k]) > limits_.max_abs_coordinate) {
        return line_error(line_number_, std::string(record_number_names[k]) + " " + quote_bytes(texts[k]) +
                                            " is beyond +-" + format_number(limits_.max_abs_coordinate) +
                                            " Angstrom (limits.max_abs_coordinate)");
      }
    }
    const double radius = values[radius_index];
    if (std::signbit(radius)) {  // also -0.0: a sign on a radius is a format error, not a zero radius
      return line_error(line_number_, "radius " + quote_bytes(texts[radius_index]) + " is negative");
    }
    if (radius > limits_.max_radius) {
      return line_error(line_number_, "radius " + quote_bytes(texts[radius_index]) + " is larger than " +
                                          format_number(limits_.max_radius) + " Angstrom (limits.max_radius)");
    }
    return status::success();
  }

  void add_atom(const std::array<double, detail::record_number_count>& values) {
    atom new_atom;
    new_atom.center = {values[x_index], values[y_index], values[z_index]};
    new_atom.charge = values[charge_index];
    new_atom.radius = values[radius_index];
    if (new_atom.radius == 0) ++molecule_.zero_radius_atoms;
    molecule_.atoms.push_back(new_atom);
  }

  result<molecule> finish() {
    if (bad_records_ > 0) return bad_records_error();
    if (molecule_.atoms.empty()) {
      return status{errc::nothing_to_mesh, "no atoms with radius > 0: the input has no ATOM or HETATM record"};
    }
    if (molecule_.zero_radius_atoms == molecule_.atoms.size()) {
      return status{errc::nothing_to_mesh, "no atoms with radius > 0: all " +
                                               std::to_string(molecule_.atoms.size()) + " atoms have radius 0"};
    }
    return std::move(molecule_);
  }

  const mesh_limits& limits_;
  std::size_t line_number_ = 0;
  std::size_t records_ = 0;  // atom records seen, read or not
  std::size_t bad_records_ = 0;
  std::vector<std::size_t> bad_lines_;  // the first max_listed_bad_lines of them
  status first_bad_record_ = status::success();
  molecule molecule_;
};

}  // namespace

namespace detail {

namespace {
std::string describe_errno(int error) { return std::error_code(error, std::generic_category()).message(); }

}  // namespace

/// The whole file, or an error: io_error when it cannot be opened or read, limit_exceeded past max_bytes.
result<std::string> read_file_bounded(const std::filesystem::path& path, std::size_t max_bytes) {
  const std::string shown_path = detail::quote_bytes(path.string(), std::numeric_limits<std::size_t>::max());
  errno = 0;
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) return status{errc::io_error, "cannot open " + shown_path + ": " + describe_errno(errno)};

  std::string bytes;
  std::error_code size_error;
  const auto size_hint = std::filesystem::file_size(path, size_error);  // only a hint: the file may change
  if (!size_error) bytes.reserve(static_cast<std::size_t>(std::min<std::uintmax_t>(size_hint, max_bytes)));

  std::array<char, 1 << 16> chunk;
  for (;;) {
    const std::size_t count = std::fread(chunk.data(), 1, chunk.size(), file.get());
    if (count > max_bytes - bytes.size()) {
      return status{errc::limit_exceeded, shown_path + " is larger than " + std::to_string(max_bytes) +
                                              " bytes (limits.max_atoms x " +
                                              std::to_string(pqr_max_bytes_per_atom) + ")"};
    }
    bytes.append(chunk.data(), count);
    if (count < chunk.size()) break;
  }
  if (std::ferror(file.get())) {
    return status{errc::io_error, "cannot read " + shown_path + ": " + describe_errno(errno)};
  }
  return bytes;
}

}  // namespace detail

std::size_t max_pqr_text_bytes(const mesh_limits& limits) noexcept {
  constexpr std::size_t largest = std::numeric_limits<std::size_t>::max();
  if (limits.max_atoms > largest / pqr_max_bytes_per_atom) return largest;
  return limits.max_atoms * pqr_max_bytes_per_atom;
}

result<molecule> parse_pqr(std::string_view text, const mesh_limits& limits) {
  return pqr_parser(limits).parse(text);
}

result<std::string> maybe_gunzip(std::string_view bytes, std::size_t max_bytes) {
  if (!detail::has_gzip_magic(bytes)) return std::string(bytes);
  return detail::gunzip(bytes, max_bytes);
}

result<molecule> read_pqr_file(const std::filesystem::path& path, const mesh_limits& limits) {
  const std::size_t max_bytes = max_pqr_text_bytes(limits);
  result<std::string> bytes = detail::read_file_bounded(path, max_bytes);
  if (!bytes) return bytes.error();
  if (!detail::has_gzip_magic(*bytes)) return parse_pqr(*bytes, limits);  // plain text: no copy
  result<std::string> text = detail::gunzip(*bytes, max_bytes);
  if (!text) return text.error();
  bytes = std::string();  // release the compressed bytes before parsing
  return parse_pqr(*text, limits);
}

}  // namespace tracemesh
