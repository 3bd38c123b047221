#pragma once
/// @file report_json.hpp
/// The per-job report as JSON: what the service returns in GET /jobs/{id} and the CLI writes with --report.
/// Schema: the MeshReport component of proto/openapi.json. Field names are snake_case; lengths in Å, areas Å²,
/// volumes Å³, angles degrees, timings seconds. Non-finite numbers are written as null.

#include <cstddef>
#include <optional>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "core/io/input_format.hpp"
#include "core/io/structure/molecule_reader.hpp"
#include "core/mesher.hpp"
#include "proto/mesh_encoders.hpp"

namespace tracemesh::proto {

/// The biological assembly meshed, when one was built from the file's symmetry operators.
struct assembly_summary {
  std::string id;              ///< the assembly id asked for (structure_options::assembly)
  std::size_t operators = 0;   ///< symmetry operators applied, over all its generators
  std::size_t atoms = 0;       ///< atoms of the assembly read (every copy, after the reader's options)
  std::size_t merged_atoms = 0;  ///< copies of an atom on a symmetry axis merged into one (pdb_mmcif_reader.hpp)
};

/// What was read: the input's format, where its radii came from (read_molecule_result, radii_source) and the
/// assembly built (none: the file's own atoms, deposited_assembly).
struct input_summary {
  input_format format = input_format::pqr;
  std::string radii = "file";  ///< "file" (PQR, xyzr) or the radii table's name ("bondi", "mantina")
  std::optional<assembly_summary> assembly;  ///< nullopt: the file's own atoms (deposited_assembly)

  input_summary() = default;
  // A constructor, not an aggregate: callers that name the format and radii only need not name the assembly.
  input_summary(input_format format_read, std::string radii_source, std::optional<assembly_summary> built = {})
      : format(format_read), radii(std::move(radii_source)), assembly(std::move(built)) {}
};

/// The summary of what read_molecule read (its assembly only when one was built).
input_summary summarize_input(const read_molecule_result& read);

/// Report of one meshing run: engine_version, parameters {density, d, t0}, input {format, radii, assembly?} (when
/// `input` is given: the caller read the molecule), method ("trace" | "lattice"),
/// method_used (method_used(): lattice when a trace job fell back), fallback (output.fallback_reason, null
/// when empty), refine ("none" | "full"), cavity_mode ("keep" | "drop", params.cavities), dropped_components
/// (enclosed components removed by cavities=drop), trace (trace_to_json when the trace path made the mesh, else
/// null), atoms_meshed,
/// zero_radius_atoms, vertices, triangles, area, volume, components [{vertices, triangles, area, volume, genus,
/// euler_characteristic, cavity, enclosed}, ...], cavities, genus, euler_characteristic, certificate {...},
/// quality {...}, achieved_density and timings {<stage name>: seconds, ..., total}.
/// Everything but `timings` is a function of the input and parameters only (params.threads is not reported).
/// method, refine and the trace parameters are echoed from `params` (what was asked), the trace counters come from
/// output.trace (what was done).
nlohmann::json report_to_json(const mesh_output& output, const mesh_params& params,
                              const std::optional<input_summary>& input = std::nullopt);

/// The parts of report_to_json, for callers that assemble their own documents.
nlohmann::json parameters_to_json(const mesh_params& params);
/// {"format": "pqr" | "pdb" | "mmcif" | "xyzr", "radii": "file" | "bondi" | "mantina"} and, when an assembly was
/// built, "assembly": {"id", "operators", "atoms", "merged_atoms"}.
nlohmann::json input_to_json(const input_summary& input);
/// The trace path's section: {parameters: {legendre_degree, step_fraction, step (Å, stats.step), line_spacing (Å,
/// stats.line_spacing), cos_bound, extreme_tolerance}, line_offset ([y, z] in units of h̃), grid_retries, lines,
/// polynomial_roots, bracketed_roots, tangent_root_intervals, arcs, polygons, extreme_points, retraced_arcs, fallback_loops,
/// welded_edges, collapsed_raw_edges, level_shifted_strips, untouched_cavities, untouched_cavities_left,
/// field_evaluations, raw_vertices, raw_triangles,
/// field_evaluations_per_vertex (field_evaluations / raw_vertices; 0 without vertices)}.
nlohmann::json trace_to_json(const trace_parameters& params, const trace_stats& stats);
nlohmann::json component_to_json(const component_report& component);
nlohmann::json certificate_to_json(const mesh_output& output);
nlohmann::json quality_to_json(const quality_report& quality);
/// What the report states about one delivered encoding (the "encodings" object of the report, keyed by format
/// name): {"bytes": encoded_bytes} and, by the format's position_encoding, for a Draco grid "position_quantization"
/// {bits, step (Å), max_position_error (Å, bound), bits_raised} and "decoded_check" (of Draco's decoding of the
/// bytes), for float32 "decoded_check" (of the float32-rounded mesh); decoded_check is {coincident_vertices,
/// degenerate_triangles, boundary_edges, non_manifold_edges, non_manifold_vertices, inconsistently_oriented_edges,
/// self_intersections, passed}. A format that refused the mesh gives {"error": {code, message}} instead.
nlohmann::json encoding_to_json(const encoder_input& input, mesh_format format, const result<std::size_t>& encoded_bytes);
nlohmann::json delivered_check_to_json(const delivered_check& check);
/// {<stage name>: seconds summed over entries of that stage, ..., "failed_attempts": failed_attempt_seconds (only
/// when > 0: see mesh_output), "total": sum of all}.
nlohmann::json timings_to_json(const std::vector<stage_timing>& timings, double failed_attempt_seconds = 0);

}  // namespace tracemesh::proto
