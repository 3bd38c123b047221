#pragma once
/// @file assembly_records.hpp
/// The text of the records that define a biological assembly, checked before gemmi builds it. gemmi 0.5.7 reads
/// PDB REMARK 350 BIOMT numbers without checking them (a damaged number reads as 0, a short line is skipped) and
/// mmCIF oper_expression values leniently (a product "(X0)(1-60)" reads as its first factor, an operator id
/// missing from _pdbx_struct_oper_list is skipped): an assembly built from such records would be wrong without a
/// word, so they are refused here, naming the line or the value, and products are expanded by the reader itself
/// (pdb_mmcif_reader.cpp). No gemmi here: plain text only.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.hpp"

namespace tracemesh::detail {

/// Checks the REMARK 350 records of biomolecule `assembly` (its "BIOMOLECULE: <id>" line up to the next
/// BIOMOLECULE line) in PDB text, lines of at most max_line_bytes, up to the first END record: every BIOMT line has
/// decimal numbers in columns 24-33, 34-43, 44-53 (a matrix row) and 59-68 (a translation), rows 1, 2, 3 of one
/// operator follow each other with one serial number (columns 20-23), and an "APPLY THE FOLLOWING TO CHAINS" line
/// comes before the first operator. Returns the number of operators found (0 when the file has no such
/// biomolecule: the caller names the ids it has). Error: errc::invalid_input naming the line.
result<std::size_t> check_biomt_records(std::string_view text, std::string_view assembly,
                                        std::size_t max_line_bytes);

/// The operator id groups of an mmCIF _pdbx_struct_assembly_gen.oper_expression, strictly: "1", "(1)", "(1-60)",
/// "(1,3,5-8)", "(A,B)" are one group (blanks around elements allowed; a range is two numbers, the first not above
/// the second), "(X0)(1-60)" two: the mmCIF dictionary's Cartesian product, applied from right to left (X0 after
/// each of 1 to 60). Errors: errc::invalid_input for an empty element, a range that is not two numbers or text
/// outside the groups; errc::limit_exceeded when the product names more than `max_names` operators.
result<std::vector<std::vector<std::string>>> operator_groups(std::string_view expression, std::size_t max_names);

/// How many operator ids gemmi 0.5.7's lenient parse_operation_expr makes of `expression` (it expands ranges
/// "a-b" digit by digit into an int without an overflow check), counted without expanding them. Errors:
/// errc::invalid_input when a range number is beyond the 32-bit range (signed overflow in gemmi),
/// errc::limit_exceeded when the ids would be more than `max_names` (gemmi would allocate every one).
result<std::size_t> gemmi_operator_id_count(std::string_view expression, std::size_t max_names);

}  // namespace tracemesh::detail
