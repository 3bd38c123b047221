#include "cli/nanoshaper/prm_file.hpp"

#include <algorithm>

#include "core/io/text_lines.hpp"
#include "core/limits.hpp"

namespace tracemesh::cli::nanoshaper {
namespace {

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string_view trimmed(std::string_view text) {
  while (!text.empty() && is_blank(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_blank(text.back())) text.remove_suffix(1);
  return text;
}

/// At most 40 bytes of a line, for messages.
std::string quoted(std::string_view text) {
  constexpr std::size_t shown = 40;
  // Appended piece by piece: g++ 12 raises a false -Wrestrict on `"'" + std::string`.
  std::string out = "'";
  out.append(text.substr(0, shown));
  out += text.size() > shown ? "...'" : "'";
  return out;
}

}  // namespace

result<prm_file> parse_prm(std::string_view text) {
  if (text.size() > max_prm_bytes) {
    return status(errc::invalid_input, "more than " + std::to_string(max_prm_bytes >> 10) +
                                           " KiB: not a NanoShaper configuration");
  }
  detail::text_lines lines(text, mesh_limits{}.max_line_bytes, "NanoShaper configuration");
  prm_file file;
  std::string_view line;
  for (;;) {
    const result<bool> more = lines.next(line);
    if (!more) return more.error();
    if (!*more) break;
    const std::string_view content = trimmed(line.substr(0, line.find('#')));
    if (content.empty()) continue;
    const std::size_t equals = content.find('=');
    if (equals == std::string_view::npos) {
      return detail::line_error(lines.line_number(), "expected Key = value, got " + quoted(content));
    }
    const std::string_view key = trimmed(content.substr(0, equals));
    if (key.empty()) return detail::line_error(lines.line_number(), "no key before '='");
    if (std::any_of(key.begin(), key.end(), is_blank)) {
      return detail::line_error(lines.line_number(), "a key has no blanks inside, got " + quoted(key));
    }
    file.entries.push_back({std::string(key), std::string(trimmed(content.substr(equals + 1))), lines.line_number()});
  }
  return file;
}

}  // namespace tracemesh::cli::nanoshaper
