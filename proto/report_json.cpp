#include "proto/report_json.hpp"

#include <cmath>

namespace tracemesh::proto {
namespace {

/// nlohmann::json turns NaN and infinities into null when dumping; doing it here keeps in-memory documents equal
/// to their parsed dumps.
nlohmann::json number(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(); }

}  // namespace

nlohmann::json parameters_to_json(const mesh_params& params) {
  return {{"density", number(params.density)}, {"d", number(params.d)}, {"t0", number(params.t0)}};
}

nlohmann::json input_to_json(const input_summary& input) {
  nlohmann::json json = {{"format", std::string(input_format_name(input.format))}, {"radii", input.radii}};
  if (input.assembly) {
    json["assembly"] = {{"id", input.assembly->id},
                        {"operators", input.assembly->operators},
                        {"atoms", input.assembly->atoms},
                        {"merged_atoms", input.assembly->merged_atoms}};
  }
  return json;
}

input_summary summarize_input(const read_molecule_result& read) {
  input_summary summary(read.format, std::string(read.radii));
  if (read.assembly != deposited_assembly) {
    summary.assembly =
        assembly_summary{read.assembly, read.assembly_operators, read.mol.atoms.size(), read.assembly_merged_atoms};
  }
  return summary;
}

nlohmann::json trace_to_json(const trace_parameters& params, const trace_stats& stats) {
  const double per_vertex =
      stats.raw_vertices == 0 ? 0.0
                              : static_cast<double>(stats.field_evaluations) / static_cast<double>(stats.raw_vertices);
  return {
      {"parameters",
       {{"legendre_degree", params.legendre_degree},
        {"step_fraction", number(params.step_fraction)},
        {"step", number(stats.step)},
        {"line_spacing", number(stats.line_spacing)},
        {"cos_bound", number(params.cos_bound)},
        {"extreme_tolerance", number(params.extreme_tolerance)}}},
      {"line_offset", stats.line_offset},
      {"grid_retries", stats.grid_retries},
      {"lines", stats.lines},
      {"proven_lines", stats.proven_lines},
      {"polynomial_roots", stats.polynomial_roots},
      {"tangent_root_intervals", stats.tangent_root_intervals},
      {"arcs", stats.arcs},
      {"bracketed_roots", stats.bracketed_roots},
      {"polygons", stats.polygons},
      {"extreme_points", stats.extreme_points},
      {"retraced_arcs", stats.retraced_arcs},
      {"untangled_points", stats.untangled_points},
      {"fallback_loops", stats.fallback_loops},
      {"welded_edges", stats.welded_edges},
      {"collapsed_raw_edges", stats.collapsed_raw_edges},
      {"level_shifted_strips", stats.level_shifted_strips},
      {"untouched_cavities", stats.untouched_cavities},
      {"untouched_cavities_left", stats.untouched_cavities_left},
      {"field_evaluations", stats.field_evaluations},
      {"raw_vertices", stats.raw_vertices},
      {"raw_triangles", stats.raw_triangles},
      {"field_evaluations_per_vertex", number(per_vertex)},
  };
}

nlohmann::json component_to_json(const component_report& component) {
  return {
      {"vertices", component.vertices},
      {"triangles", component.triangles},
      {"area", number(component.area)},
      {"volume", number(component.volume)},
      {"genus", component.genus},
      {"euler_characteristic", component.euler_characteristic},
      {"cavity", component.cavity},
      {"enclosed", component.enclosed},
  };
}

nlohmann::json certificate_to_json(const mesh_output& output) {
  const mesh_report& report = output.report;
  return {
      {"certified", output.certified},
      {"boundary_edges", report.boundary_edges},
      {"non_manifold_edges", report.non_manifold_edges},
      {"non_manifold_vertices", report.non_manifold_vertices},
      {"inconsistently_oriented_edges", report.inconsistently_oriented_edges},
      {"degenerate_triangles", report.degenerate_triangles},
      {"unreferenced_vertices", report.unreferenced_vertices},
      {"self_intersections", report.self_intersections},
      {"inward_oriented_components", report.inward_oriented_components},
      {"folded_triangles", report.folded_triangles},
      {"near_duplicate_vertex_pairs", report.near_duplicate_vertex_pairs},
      {"max_surface_distance", number(output.max_surface_distance)},
      {"field_cutoff_error", number(output.field_cutoff_error)},
  };
}

nlohmann::json quality_to_json(const quality_report& quality) {
  return {
      {"edge_ratio_mean", number(quality.edge_ratio_mean)},
      {"edge_ratio_min", number(quality.edge_ratio_min)},
      {"edge_ratio_histogram", quality.edge_ratio_histogram},
      {"fraction_below_0_2", number(quality.fraction_below_0_2)},
      {"min_angle_deg", number(quality.min_angle_deg)},
      {"shortest_edge", number(quality.shortest_edge)},
      {"median_edge", number(quality.median_edge)},
      {"longest_edge", number(quality.longest_edge)},
  };
}

nlohmann::json timings_to_json(const std::vector<stage_timing>& timings, double failed_attempt_seconds) {
  nlohmann::json json = nlohmann::json::object();
  double total = 0;
  if (failed_attempt_seconds > 0) {
    json["failed_attempts"] = failed_attempt_seconds;
    total += failed_attempt_seconds;
  }
  for (const stage_timing& timing : timings) {
    const char* name = stage_name(timing.stage);
    json[name] = json.value(name, 0.0) + timing.seconds;
    total += timing.seconds;
  }
  json["total"] = total;
  return json;
}

nlohmann::json report_to_json(const mesh_output& output, const mesh_params& params,
                              const std::optional<input_summary>& input) {
  const mesh_report& report = output.report;
  nlohmann::json components = nlohmann::json::array();
  for (const component_report& component : report.components) components.push_back(component_to_json(component));
  const mesh_method used = method_used(params.method, output);
  nlohmann::json doc = {
      {"engine_version", engine_version},
      {"parameters", parameters_to_json(params)},
      {"method", method_name(params.method)},
      {"method_used", method_name(used)},
      {"fallback", output.fallback_reason.empty() ? nlohmann::json() : nlohmann::json(output.fallback_reason)},
      {"refine", refine_name(params.refine)},
      {"cavity_mode", cavity_mode_name(params.cavities)},
      {"dropped_components", output.dropped_components},
      {"trace",
       used == mesh_method::trace ? trace_to_json(params.trace, output.trace) : nlohmann::json()},
      {"atoms_meshed", output.atoms_meshed},
      {"zero_radius_atoms", output.zero_radius_atoms},
      {"vertices", report.vertices},
      {"triangles", report.triangles},
      {"area", number(report.area)},
      {"volume", number(report.volume)},
      {"components", std::move(components)},
      {"cavities", report.cavities},
      {"genus", report.genus},
      {"euler_characteristic", report.euler_characteristic},
      {"certificate", certificate_to_json(output)},
      {"quality", quality_to_json(report.quality)},
      {"achieved_density", number(report.achieved_density)},
      {"timings", timings_to_json(output.timings, output.failed_attempt_seconds)},
  };
  if (input) doc["input"] = input_to_json(*input);
  return doc;
}

}  // namespace tracemesh::proto

namespace tracemesh::proto {

nlohmann::json delivered_check_to_json(const delivered_check& check) {
  return {{"coincident_vertices", check.coincident_vertices},
          {"degenerate_triangles", check.degenerate_triangles},
          {"boundary_edges", check.boundary_edges},
          {"non_manifold_edges", check.non_manifold_edges},
          {"non_manifold_vertices", check.non_manifold_vertices},
          {"inconsistently_oriented_edges", check.inconsistently_oriented_edges},
          {"self_intersections", check.self_intersections},
          {"passed", check.passed()}};
}

nlohmann::json encoding_to_json(const encoder_input& input, mesh_format format, const result<std::size_t>& encoded_bytes) {
  if (!encoded_bytes) {
    const status& error = encoded_bytes.error();
    return {{"error", {{"code", errc_name(error.code())}, {"message", error.message()}}}};
  }
  nlohmann::json doc = {{"bytes", *encoded_bytes}};
  switch (format_info(format).positions) {
    case position_encoding::decimal: break;
    case position_encoding::draco_grid: {
      const draco_encoding& draco = *input.draco();  // set: the format encoded
      doc["position_quantization"] = {{"bits", draco.grid.bits},
                                      {"step", draco.grid.step()},
                                      {"max_position_error", draco_settings::max_position_error},
                                      {"bits_raised", draco.bits_raised}};
      doc["decoded_check"] = delivered_check_to_json(draco.decoded);
      break;
    }
    case position_encoding::float32: doc["decoded_check"] = delivered_check_to_json(input.float32_check()); break;
  }
  return doc;
}

}  // namespace tracemesh::proto
