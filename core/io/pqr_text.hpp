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

/// Takes the last record_number_count numeric fields of `fields` (the record after its name), splitting fused
/// fields at each '-' that directly follows a digit. Fills `out` from the back (out[4] = radius text first) and
/// returns how many it found (< record_number_count when the record has too few fields; then only the last
/// entries of `out` are set). Does not check that the fields are numbers.
std::size_t take_record_numbers(std::string_view fields, record_numbers_text& out);

/// Offset of the first byte of `bytes` that does not belong to a well-formed UTF-8 sequence (overlong forms,
/// surrogates and code points above U+10FFFF are ill-formed), or std::string_view::npos when it is all UTF-8.
std::size_t find_invalid_utf8(std::string_view bytes);

}  // namespace tracemesh::detail
