#pragma once
/// @file pqr_text.hpp
/// Private helpers of the PQR reader: strict number parsing, splitting the numeric tail of a record, UTF-8
/// validation and quoting input safely in error messages. Not part of the public API.

#include <array>
#include <cstddef>
#include <string>
#include <string_view>

namespace tracemesh::detail {

/// Raw input bytes quoted in one error message, at most.
inline constexpr std::size_t max_quoted_bytes = 40;

/// `bytes` made safe for a one-line message: printable ASCII kept, anything else (control bytes, bytes ≥ 0x80,
/// and the backslash itself) written as \xNN. Only the first `max_bytes` input bytes are used; "..." marks a cut.
std::string quote_bytes(std::string_view bytes, std::size_t max_bytes = max_quoted_bytes);

/// Shortest decimal text that reads back as `value` ("1e+06", "10", "0.5"); locale-independent.
std::string format_number(double value);

enum class number_error {
  none,
  not_a_number,  ///< not a plain decimal number: letters, commas, hex, trailing characters, empty
  out_of_range,  ///< a decimal number beyond double's range, either way ("1e400", "1e-400")
  not_finite,    ///< NaN or an infinity
};

struct parsed_number {
  double value = 0;
  number_error error = number_error::none;
};

/// Reads the whole of `field` as a finite decimal double with std::from_chars, plus an optional leading '+'.
parsed_number parse_number(std::string_view field);

/// The five numbers ending an atom record, in order x, y, z, charge, radius.
inline constexpr std::size_t record_number_count = 5;
using record_numbers_text = std::array<std::string_view, record_number_count>;

/// An atom record cut into the fields before its five numbers and the numbers themselves.
struct atom_record_fields {
  /// x y z charge radius, filled from the back (numbers[4] = radius text first); only the last
  /// `number_count` entries are set when the record has fewer than five numeric fields.
  record_numbers_text numbers;
  std::size_t number_count = 0;
  /// Whitespace-separated fields before the numbers (serial, names, chain id, residue number), the piece of a
  /// fused field left in front of x included ("561" of "561-10.573").
  std::size_t leading_count = 0;
  /// The last of those fields, the one just before x: the residue number in both PQR variants; empty when none.
  std::string_view residue_field;
};

/// Splits the fields of an atom record (the text after its record name): the last record_number_count numeric
/// fields, splitting fused fields at each '-' that directly follows a digit, and the count of the fields before
/// them. Does not check that the fields are numbers. Linear in fields.size().
atom_record_fields split_atom_record(std::string_view fields);

/// Offset of the first byte of `bytes` that does not belong to a well-formed UTF-8 sequence (overlong forms,
/// surrogates and code points above U+10FFFF are ill-formed), or std::string_view::npos when it is all UTF-8.
std::size_t find_invalid_utf8(std::string_view bytes);

}  // namespace tracemesh::detail
