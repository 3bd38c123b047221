#pragma once
/// @file prm_file.hpp
/// The text of a NanoShaper configuration file (.prm): `Key = value` lines. The keys and what tracemesh does with
/// each are nanoshaper_job.hpp's; this file only splits the text.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.hpp"

namespace tracemesh::cli::nanoshaper {

/// One `Key = value` line of a .prm file.
struct prm_entry {
  std::string key;    ///< as written (NanoShaper's keys are case-sensitive), surrounding blanks removed
  std::string value;  ///< the text after the first '=', comment and surrounding blanks removed; may be empty
  std::size_t line = 0;  ///< 1-based line number, for messages
};

/// A parsed .prm file: its entries in file order (a repeated key appears once per line that sets it).
struct prm_file {
  std::vector<prm_entry> entries;
};

/// Upper bound on the bytes of a .prm file: the longest configuration NanoShaper ships is ~7 KB, so a larger file is
/// not a configuration (a molecule or a mesh named by mistake).
inline constexpr std::size_t max_prm_bytes = 1 << 20;

/// Splits .prm text as NanoShaper reads it: '#' starts a comment (anywhere on a line), blank lines are skipped,
/// every other line is `Key = value` with a non-empty key; LF or CRLF line ends.
/// NanoShaper appends a line without '=' to the previous value; tracemesh refuses it, since in the files clients
/// write it is always a typo. Errors (errc::invalid_input, "line N: ..."): a line without '=', an empty key, a key
/// with blanks inside, a NUL or other control byte, more than max_prm_bytes.
result<prm_file> parse_prm(std::string_view text);

}  // namespace tracemesh::cli::nanoshaper
