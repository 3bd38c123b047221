#include "core/io/structure/assembly_records.hpp"

#include <algorithm>
#include <limits>

#include "core/io/pqr_text.hpp"
#include "core/io/text_lines.hpp"

namespace tracemesh::detail {

namespace {

bool is_blank_char(char c) { return c == ' ' || c == '\t'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// Columns `first`..`last` (1-based, inclusive) of `line`, cut at its end.
std::string_view columns(std::string_view line, std::size_t first, std::size_t last) {
  if (line.size() < first) return {};
  return line.substr(first - 1, last - first + 1);
}

/// gemmi's REMARK 350 test: a REMARK record whose columns 8-10 read 350, longer than 11 columns.
bool is_remark_350(std::string_view line) {
  return has_record_prefix(line, "REMA") && line.size() > 11 && trimmed(columns(line, 8, 10)) == "350";
}

/// "REMARK 350 BIOMOLECULE: 1": gemmi wants the colon in column 23 and reads the id from columns 24-43.
bool is_biomolecule_line(std::string_view line) {
  return columns(line, 12, 22) == "BIOMOLECULE" && columns(line, 23, 23) == ":";
}
bool is_apply_line(std::string_view line) {
  return columns(line, 12, 40) == "APPLY THE FOLLOWING TO CHAINS" && columns(line, 41, 41) == ":";
}
bool is_biomt_line(std::string_view line) { return columns(line, 12, 18) == "  BIOMT"; }

/// BIOMT columns, as gemmi's read_matrix reads them.
struct biomt_column {
  const char* name;
  std::size_t first, last;
};
constexpr biomt_column biomt_numbers[] = {
    {"matrix column 1", 24, 33}, {"matrix column 2", 34, 43}, {"matrix column 3", 44, 53}, {"translation", 59, 68}};

status check_biomt_line(std::string_view line, std::size_t number, char row, std::string_view serial,
                        std::string_view expected_serial) {
  if (columns(line, 19, 19) != std::string_view(&row, 1)) {
    return line_error(number, "BIOMT row '" + quote_bytes(columns(line, 19, 19)) + "' (column 19) where row " +
                                  std::string(1, row) + " of an operator was expected");
  }
  if (row != '1' && serial != expected_serial) {
    return line_error(number, "BIOMT row " + std::string(1, row) + " of operator '" + quote_bytes(serial) +
                                  "' follows the rows of operator '" + quote_bytes(expected_serial) + "'");
  }
  for (const biomt_column& column : biomt_numbers) {
    const std::string_view field = trimmed(columns(line, column.first, column.last));
    if (parse_number(field).error != number_error::none) {
      return line_error(number, "BIOMT " + std::string(column.name) + " '" + quote_bytes(field) + "' (columns " +
                                    std::to_string(column.first) + "-" + std::to_string(column.last) +
                                    ") is not a decimal number");
    }
  }
  return status::success();
}

/// gemmi stops at "END" followed by a blank or the end of the line (not ENDMDL).
bool is_end_record(std::string_view line) {
  return has_record_prefix(line, "END") && (line.size() == 3 || is_blank_char(line[3]));
}

/// Whether the range bound gemmi's no_sign_atoi reads from `digits` (leading blanks, then digits) is below the
/// int maximum: gemmi sums it in an int, and counts up to it with ++ (the maximum itself would overflow).
bool fits_int(std::string_view digits) {
  std::size_t i = 0;
  while (i < digits.size() && is_blank_char(digits[i])) ++i;
  long long value = 0;
  for (; i < digits.size() && is_digit(digits[i]); ++i) {
    value = value * 10 + (digits[i] - '0');
    if (value >= std::numeric_limits<int>::max()) return false;
  }
  return true;
}
long long leading_number(std::string_view digits) {
  std::size_t i = 0;
  while (i < digits.size() && is_blank_char(digits[i])) ++i;
  long long value = 0;
  for (; i < digits.size() && is_digit(digits[i]); ++i) value = value * 10 + (digits[i] - '0');
  return value;
}

bool all_digits(std::string_view text) {
  return !text.empty() && std::all_of(text.begin(), text.end(), is_digit);
}

status expression_error(std::string_view expression, const std::string& what) {
  return {errc::invalid_input,
          "mmCIF _pdbx_struct_assembly_gen.oper_expression '" + quote_bytes(expression, 40) + "': " + what};
}
status too_many_ids(std::string_view expression, std::size_t max_names) {
  return {errc::limit_exceeded, "mmCIF _pdbx_struct_assembly_gen.oper_expression '" + quote_bytes(expression, 40) +
                                    "' names more than " + std::to_string(max_names) +
                                    " operators (limits.max_atoms: each copies at least one atom)"};
}

}  // namespace

result<std::size_t> check_biomt_records(std::string_view text, std::string_view assembly,
                                        std::size_t max_line_bytes) {
  text_lines lines(text, max_line_bytes, "PDB");
  bool inside = false;   // between the requested BIOMOLECULE line and the next one
  bool applied = false;  // an APPLY THE FOLLOWING TO CHAINS line seen inside
  char row = '1';        // the BIOMT row expected next
  std::string serial;    // the serial number of the operator being read
  std::size_t operators = 0;
  std::string_view line;
  for (;;) {
    result<bool> more = lines.next(line);
    if (!more) return more.error();
    if (!*more || is_end_record(line)) break;
    if (!is_remark_350(line)) continue;
    if (is_biomolecule_line(line)) {
      if (inside) break;
      inside = trimmed(columns(line, 24, 43)) == assembly;
      continue;
    }
    if (!inside) continue;
    if (is_apply_line(line)) applied = true;
    if (!is_biomt_line(line)) continue;
    if (!applied) {
      return line_error(lines.line_number(), "BIOMT operator of biomolecule " + quote_bytes(assembly) +
                                                 " before its APPLY THE FOLLOWING TO CHAINS line");
    }
    const std::string_view this_serial = trimmed(columns(line, 20, 23));
    if (status checked = check_biomt_line(line, lines.line_number(), row, this_serial, serial); !checked) {
      return checked;
    }
    serial = std::string(this_serial);
    if (row == '3') ++operators;
    row = row == '3' ? '1' : static_cast<char>(row + 1);
  }
  if (row != '1') {
    return status{errc::invalid_input, "REMARK 350 biomolecule " + quote_bytes(assembly) + ": operator '" +
                                           quote_bytes(serial) + "' has BIOMT rows 1 to " +
                                           std::string(1, static_cast<char>(row - 1)) + " only"};
  }
  return operators;
}

namespace {

/// The ids of one group's text (between its parentheses, or the whole expression without them), appended to `ids`
/// while fewer than `max_names`.
status append_group_ids(std::string_view expression, std::string_view group, std::size_t max_names,
                        std::vector<std::string>& ids) {
  std::size_t begin = 0;
  for (;;) {
    const std::size_t end = std::min(group.find(',', begin), group.size());
    const std::string_view element = trimmed(group.substr(begin, end - begin));
    if (element.empty() || element.find_first_of("()") != std::string_view::npos) {
      return expression_error(expression, "an empty or bracketed element");
    }
    if (const std::size_t dash = element.find('-'); dash != std::string_view::npos) {
      const std::string_view low = trimmed(element.substr(0, dash)), high = trimmed(element.substr(dash + 1));
      if (!all_digits(low) || !all_digits(high) || !fits_int(low) || !fits_int(high) ||
          leading_number(low) > leading_number(high)) {
        return expression_error(expression, "the range '" + quote_bytes(element) +
                                                "' is not two numbers, the first not above the second");
      }
      for (long long id = leading_number(low); id <= leading_number(high); ++id) {
        if (ids.size() == max_names) return too_many_ids(expression, max_names);
        ids.push_back(std::to_string(id));
      }
    } else {
      if (ids.size() == max_names) return too_many_ids(expression, max_names);
      ids.emplace_back(element);
    }
    if (end == group.size()) return status::success();
    begin = end + 1;
  }
}

}  // namespace

result<std::vector<std::vector<std::string>>> operator_groups(std::string_view expression, std::size_t max_names) {
  std::vector<std::vector<std::string>> groups;
  std::string_view rest = trimmed(expression);
  if (rest.empty() || rest.front() != '(') {
    groups.emplace_back();
    if (status read = append_group_ids(expression, rest, max_names, groups.back()); !read) return read;
    return groups;
  }
  std::size_t product = 1;  // operators the groups make so far
  while (!rest.empty()) {
    if (rest.front() != '(') return expression_error(expression, "text between or after the parenthesised groups");
    const std::size_t close = rest.find(')');
    if (close == std::string_view::npos) return expression_error(expression, "no closing parenthesis");
    groups.emplace_back();
    if (status read = append_group_ids(expression, rest.substr(1, close - 1), max_names, groups.back()); !read) {
      return read;
    }
    if (groups.back().size() > max_names / product) return too_many_ids(expression, max_names);
    product *= groups.back().size();
    rest = trimmed(rest.substr(close + 1));
  }
  return groups;
}

result<std::size_t> gemmi_operator_id_count(std::string_view expression, std::size_t max_names) {
  // gemmi's parse_operation_expr: elements separated by ',' up to the first ')' when the text starts with '(';
  // an element with a '-' before its end is the range no_sign_atoi(start)..no_sign_atoi(after the '-').
  std::size_t start = 0;
  std::size_t close = std::string_view::npos;
  if (!expression.empty() && expression.front() == '(') {
    start = 1;
    close = expression.find(')');
  }
  std::size_t count = 0;
  for (;;) {
    const std::size_t separator = std::min(expression.find(',', start), close);
    const std::size_t minus = expression.find('-', start);
    if (minus < separator) {
      const std::string_view low = expression.substr(start), high = expression.substr(minus + 1);
      if (!fits_int(low) || !fits_int(high)) {
        return expression_error(expression, "a range bound beyond the 32-bit range");
      }
      const long long first = leading_number(low), last = leading_number(high);
      if (last >= first) count += static_cast<std::size_t>(last - first + 1);
    } else {
      ++count;
    }
    if (count > max_names) return too_many_ids(expression, max_names);
    if (separator == close || separator >= expression.size()) return count;
    start = separator + 1;
  }
}

}  // namespace tracemesh::detail
