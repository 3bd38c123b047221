#pragma once
// Damaged copies of real PQR text for the tests of bad input (issue 12, finding 8: a missing column).
#include <cstddef>
#include <sstream>
#include <string>
#include <vector>

namespace tracemesh::testing {

/// The whitespace-separated fields of `line`.
inline std::vector<std::string> split_fields(const std::string& line) {
  std::istringstream words(line);
  std::vector<std::string> fields;
  for (std::string word; words >> word;) fields.push_back(word);
  return fields;
}

inline std::string join_fields(const std::vector<std::string>& fields) {
  std::string out;
  for (const std::string& word : fields) out += (out.empty() ? "" : " ") + word;
  return out;
}

/// `text` with `chain` inserted as a chain id (field 4) into every ATOM/HETATM line of the 10-field layout:
/// the 11-field layout of the same atoms.
inline std::string with_chain_id(const std::string& text, const std::string& chain) {
  std::istringstream lines(text);
  std::string out;
  for (std::string line; std::getline(lines, line);) {
    std::vector<std::string> fields = split_fields(line);
    if (fields.size() == 10 && (fields[0] == "ATOM" || fields[0] == "HETATM")) {
      fields.insert(fields.begin() + 4, chain);
      line = join_fields(fields);
    }
    out += line + '\n';
  }
  return out;
}

/// `text` with the whitespace-separated field `field` (0-based, 0 = the record name) removed from line `line`
/// (1-based); that line is rewritten with single spaces, every other line is kept byte for byte.
inline std::string without_field(const std::string& text, std::size_t line, std::size_t field) {
  std::string out;
  std::size_t begin = 0;
  for (std::size_t number = 1; begin < text.size(); ++number) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    std::string current = text.substr(begin, end - begin);
    if (number == line) {
      std::vector<std::string> fields = split_fields(current);
      if (field < fields.size()) fields.erase(fields.begin() + static_cast<std::ptrdiff_t>(field));
      current = join_fields(fields);
    }
    out += current;
    if (end < text.size()) out += '\n';
    begin = end + 1;
  }
  return out;
}

}  // namespace tracemesh::testing
