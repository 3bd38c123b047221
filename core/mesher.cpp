#include "core/mesher.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>

#include "core/analysis/enclosure.hpp"
#include "core/atom_resolution.hpp"
#include "core/field/band_culling.hpp"
#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"
#include "core/lattice/lattice_mesher.hpp"
#include "core/release_memory.hpp"
#include "core/remesh/remesh.hpp"
#include "core/trace/trace_mesher.hpp"

namespace tracemesh {
namespace {

/// Vertices lie on the surface to this distance (Å) or the mesh is not certified.
constexpr double surface_distance_tolerance = 1e-3;

/// Edge length of an equilateral mesh with `density` vertices per Å² (a closed mesh has about twice as many
/// triangles as vertices, each of area √3/4·L²).
double target_edge_length(double density) { return mesh_edge_length(density); }

/// Cutoff tolerance (relative to t0) of the field the trace path walks on between lines: its contour lies within
/// ~1e-3 Å of the exact one and it sums about half as many atoms (docs/method.md); a strip whose walk conflicts is
/// traced again on the exact field.
constexpr double trace_walk_tolerance = 1e-3;

/// Outer iterations of the quality pass on the trace path's polygons, which already have about the output's
/// density (remesh_options::iterations, 3, is for marching-tetrahedra input): docs/method.md, quality pass.
constexpr int trace_refine_iterations = 2;

/// Meshes of fewer raw triangles have their quality pass's final whole-mesh check (self-intersections, inward
/// components) left to the certificate, which makes the same tests: on fas2 the check took 3 of the 48 ms. Should the
/// certificate fail, the pass runs again with the check. Measured on the ladder at 1 and 2 v/Å², both paths: no
/// whole-mesh pass of gly, adp, villin_1vii, fas2 or mache (up to 82,834 raw triangles) failed its check, while
/// those of achbp and 1ihm_asu at 1 v/Å² (75,944 and 97,860) did, for which running the pass twice would cost more
/// than the check saves.
constexpr std::size_t unchecked_quality_pass_triangles = 20'000;

/// Raw meshes of fewer triangles hand no freed memory back to the system before the quality pass: their front end
/// freed a few megabytes, and malloc_trim's walk of every thread's heap, then the page faults of the pass reusing what
/// it released, cost more than keeping them. Larger raw meshes trim, for their peak memory (a large molecule's front
/// end leaves much of the heap fragmented, release_memory.hpp), and to them the trim's milliseconds are small.
constexpr std::size_t trimmed_from_raw_triangles = 20'000;

/// The trace path's line grids, in units of h̃ (trace_stats::line_offset), attempt by attempt. A trace that cannot
/// close a cell or whose mesh fails a check (at sharp kernels, d ≤ −8 in the README's sweep, a strip plane can pass
/// within a hair of where the surface is tangent to it, and no walk gets past that point) is tried again on the
/// next grid, and only after the last one meshed by the lattice path. Each grid is at least h̃/4 away from the
/// others on both axes. docs/method.md: how often each was needed.
constexpr std::array<line_grid_offset, 3> trace_line_grids{{{0, 0}, {0.5, 0.5}, {0.25, 0.75}}};

/// Lattice spacing relative to the target edge length (see docs/method.md: sampling step).
constexpr double lattice_spacing_factor = 1.0;

status cancelled_status() { return {errc::cancelled, "meshing was cancelled"}; }

std::string format_number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

/// Outward unit normals (−∇φ/|∇φ|) and the dominant atom of every vertex; returns the largest distance of a vertex
/// from the surface, |φ − t0| / |∇φ| (one field pass for all three).
double finish_vertices(const gaussian_field& field, surface_mesh& mesh) {
  mesh.normals.resize(mesh.positions.size());
  mesh.atom_index.resize(mesh.positions.size());
  std::vector<double> distances(mesh.positions.size());
  tbb::parallel_for(std::size_t{0}, mesh.positions.size(), [&](std::size_t v) {
    const gaussian_field::point_probe probe = field.probe(mesh.positions[v]);
    mesh.normals[v] = normalized(-probe.gradient);
    mesh.atom_index[v] = probe.dominant_atom;
    distances[v] = probe.surface_distance(field.t0());
  });
  return distances.empty() ? 0.0 : *std::max_element(distances.begin(), distances.end());
}

std::string certificate_failure(const mesh_output& out) {
  const mesh_report& r = out.report;
  std::ostringstream why;
  why << "mesh failed its certificate (boundary edges " << r.boundary_edges << ", non-manifold edges "
      << r.non_manifold_edges << ", non-manifold vertices " << r.non_manifold_vertices << ", misoriented edges "
      << r.inconsistently_oriented_edges << ", degenerate triangles " << r.degenerate_triangles
      << ", self-intersections " << r.self_intersections << ", inward components " << r.inward_oriented_components
      << ", folded triangles " << r.folded_triangles << ", max surface distance " << out.max_surface_distance << " Å)";
  return why.str();
}

/// Sets component_report::enclosed from the report's vertex labels, which are dropped afterwards (the encoders
/// label their own).
void flag_enclosed_components(mesh_output& out) {
  const std::vector<bool> enclosed = enclosed_components(out.mesh, out.report);
  for (std::size_t c = 0; c < enclosed.size(); ++c) out.report.components[c].enclosed = enclosed[c];
  std::vector<std::uint32_t>().swap(out.report.vertex_component);
}

/// cavities=drop: removes the components enclosed by another one, before the vertices are finished and the mesh
/// certified (the certificate is the result's). Components are found without the self-intersection test.
void drop_enclosed_components(mesh_output& out) {
  analysis_options labels_only;
  labels_only.check_self_intersections = false;
  labels_only.label_vertices = true;
  const mesh_report labelled = analyze_mesh(out.mesh, labels_only);
  const std::vector<bool> enclosed = enclosed_components(out.mesh, labelled);
  out.dropped_components = static_cast<std::size_t>(std::count(enclosed.begin(), enclosed.end(), true));
  if (out.dropped_components > 0) {
    out.dropped_triangles = remove_components(out.mesh, labelled.vertex_component, enclosed);
  }
}

/// The error for a sampling that found no surface point: φ tends to 0 away from the atoms, so where it reaches t0 at
/// an atom's centre the surface exists and was too small for the lines (or lattice) `spacing` Å apart: the user's
/// density is too low for it. Otherwise the surface is empty as far as the sampling and the atom centres tell.
status no_surface_found(const molecule& mol, const gaussian_field& field, const mesh_params& params,
                        double spacing) {
  double highest = 0;
  std::size_t at = 0;
  for (std::size_t i = 0; i < mol.atoms.size(); ++i) {
    if (mol.atoms[i].radius == 0) continue;
    const double phi = field.value(mol.atoms[i].center);
    if (phi > highest) highest = phi, at = i;
  }
  std::ostringstream why;
  if (highest >= params.t0) {
    why << "the sampling at density " << params.density << " (" << spacing
        << " Å apart) found no point of the surface φ = t0, which exists (φ = " << highest << " at the centre of atom "
        << at + 1 << "): it is smaller than that spacing; raise the density";
    return status{errc::unresolvable_input, why.str()};
  }
  why << "the surface φ = t0 is empty for these atoms and parameters (φ is at most " << highest
      << " at the atoms' centres, below t0 = " << params.t0 << ")";
  return status{errc::nothing_to_mesh, why.str()};
}

/// The molecule moved by `shift` (Å).
molecule translated(const molecule& mol, const vec3& shift) {
  molecule out = mol;
  for (atom& a : out.atoms) a.center += shift;
  return out;
}

/// The raw mesh of `mol` by params.method on the lattice of `spacing` anchored at the origin (stages culling to
/// triangulating). `field` is mol's.
result<surface_mesh> raw_mesh_at_origin(const molecule& mol, const gaussian_field& field, const mesh_params& params,
                                        double spacing, const mesh_limits& limits, progress_token& progress,
                                        stage_clock& clock, trace_stats& stats) {
  auto lat = make_lattice(field, spacing, limits);
  if (!lat) return lat.error();
  auto blocks = cull_blocks(field, *lat, progress);
  if (!blocks) return blocks.error();
  clock.finish(mesh_stage::culling);
  if (params.method == mesh_method::lattice) return mesh_lattice_blocks(field, *lat, *blocks, limits, progress, clock);
  const gaussian_field walk_field(mol, params.d, params.t0, trace_walk_tolerance);
  return mesh_trace_blocks(field, walk_field, *lat, *blocks, params.trace, params.refine == refine_mode::none, limits,
                           progress, clock, stats);
}

/// The raw mesh with the trace path's lines at y = (j + line_offset[0])·h̃, z = (k + line_offset[1])·h̃: the
/// molecule is meshed moved by −offset·h̃ (the lattice stays anchored at the origin) and the mesh moved back.
result<surface_mesh> raw_mesh(const molecule& mol, const gaussian_field& field, const mesh_params& params,
                              double spacing, const line_grid_offset& line_offset, const mesh_limits& limits,
                              progress_token& progress, stage_clock& clock, trace_stats& stats) {
  if (line_offset == line_grid_offset{}) {
    return raw_mesh_at_origin(mol, field, params, spacing, limits, progress, clock, stats);
  }
  const vec3 shift{0, -line_offset[0] * spacing, -line_offset[1] * spacing};
  const molecule moved = translated(mol, shift);
  const gaussian_field moved_field(moved, params.d, params.t0);
  result<surface_mesh> raw = raw_mesh_at_origin(moved, moved_field, params, spacing, limits, progress, clock, stats);
  if (raw) {
    for (vec3& p : raw->positions) p -= shift;
  }
  return raw;
}

/// The quality pass (refine=full) on `mesh`; `unchecked_below` as remesh_options::unchecked_below_triangles.
result<remesh_stats> refine_mesh(surface_mesh& mesh, const gaussian_field& field, const mesh_params& params,
                                 double edge, const mesh_limits& limits, std::size_t unchecked_below,
                                 progress_token& progress) {
  remesh_options refine;
  refine.target_edge = edge;
  refine.trust_input_normals = true;  // the root solver's (lattice) or the trace's
  if (params.method == mesh_method::trace) refine.iterations = trace_refine_iterations;
  refine.max_triangles = limits.max_triangles;
  refine.unchecked_below_triangles = unchecked_below;
  result<remesh_stats> refined = remesh_surface(mesh, field, refine, progress);
  if (!refined && refined.error().code() == errc::invalid_argument) {
    // Its input is the engine's own raw mesh and options, never the user's: a refusal is the engine's failure
    // (a raw trace mesh left non-manifold where a contour pinches), which the trace path's retries then handle.
    return status{errc::internal_error, "the quality pass refused the raw mesh: " + refined.error().message()};
  }
  return refined;
}

/// Whether a mesh of the `path` with this report is free of folds as far as the certificate asks. No step of the
/// trace path makes a triangle that faces against the field normals at all three corners, so one there fails the
/// certificate (and the job goes on to the next line grid). The lattice path's marching tetrahedra cut a crevice
/// narrower than the lattice with triangles standing across it, and the collapses of their edges leave a few
/// (achbp at 1 v/Å²: 6 of 42, the quality pass keeps 4): its meshes report their folds without failing on them.
bool folds_allowed_by_certificate(mesh_method path, const mesh_report& report) {
  return path == mesh_method::lattice || report.folded_triangles == 0;
}

/// Drops the enclosed components when asked, then the certificate of out.mesh: normals and dominant atoms of its
/// vertices, its report, and whether it is certified.
void certify(mesh_output& out, const gaussian_field& field, const mesh_params& params) {
  if (params.cavities == cavity_mode::drop) drop_enclosed_components(out);
  out.max_surface_distance = finish_vertices(field, out.mesh);
  analysis_options labelled;
  labelled.label_vertices = true;
  out.report = analyze_mesh(out.mesh, labelled);
  flag_enclosed_components(out);
  out.certified = out.report.topologically_certified() && folds_allowed_by_certificate(params.method, out.report) &&
                  out.max_surface_distance <= surface_distance_tolerance;
}

result<mesh_output> run_pipeline(const molecule& mol, const mesh_params& params, const mesh_limits& limits,
                                 const line_grid_offset& line_offset, progress_token& progress) {
  mesh_output out;
  out.method = params.method;
  out.refine = params.refine;
  out.cavities = params.cavities;
  stage_clock clock(out.timings);
  out.zero_radius_atoms = static_cast<std::size_t>(
      std::count_if(mol.atoms.begin(), mol.atoms.end(), [](const atom& a) { return a.radius == 0; }));
  out.atoms_meshed = mol.atoms.size() - out.zero_radius_atoms;
  if (out.atoms_meshed == 0) return status{errc::nothing_to_mesh, "no atoms with radius > 0"};

  const gaussian_field field(mol, params.d, params.t0);
  out.field_cutoff_error = field.cutoff_error_bound() / params.t0;
  const double edge = target_edge_length(params.density);
  const double spacing = params.method == mesh_method::trace
                             ? trace_line_spacing(params.density)
                             : edge * lattice_spacing_factor;
  out.trace.line_offset = line_offset;
  result<surface_mesh> raw = raw_mesh(mol, field, params, spacing, line_offset, limits, progress, clock, out.trace);
  if (!raw && raw.error().code() == errc::nothing_to_mesh) return no_surface_found(mol, field, params, spacing);
  if (!raw) return raw.error();
  out.mesh = std::move(*raw);
  if (out.mesh.triangles.size() >= trimmed_from_raw_triangles) release_freed_memory();

  // A small mesh's quality pass leaves its final check to the certificate, which repeats it; should the certificate
  // fail, the pass runs again from the raw mesh, checked (its check then freezes what it refuses).
  const bool refined = params.refine == refine_mode::full;
  surface_mesh raw_for_checked_pass;
  bool unchecked = false;
  if (refined) {
    // One decision: the pass may skip its check only when the raw mesh was kept for the checked one.
    const bool may_skip_check = out.mesh.triangles.size() < unchecked_quality_pass_triangles;
    if (may_skip_check) raw_for_checked_pass = out.mesh;
    result<remesh_stats> pass = refine_mesh(out.mesh, field, params, edge, limits,
                                            may_skip_check ? unchecked_quality_pass_triangles : 0, progress);
    if (!pass) return pass.error();
    unchecked = pass->unchecked;
    clock.finish(mesh_stage::refining);
  }
  if (!progress.report(mesh_stage::certifying, 0)) return cancelled_status();
  certify(out, field, params);
  clock.finish(mesh_stage::certifying);
  if (!out.certified && unchecked) {
    out.mesh = std::move(raw_for_checked_pass);
    result<remesh_stats> pass = refine_mesh(out.mesh, field, params, edge, limits, 0, progress);
    if (!pass) return pass.error();
    clock.finish(mesh_stage::refining);
    certify(out, field, params);
    clock.finish(mesh_stage::certifying);
  }
  if (!out.certified) return status{errc::internal_error, certificate_failure(out)};
  progress.report(mesh_stage::done, 1);
  return out;
}

/// The trace path's internal errors (a cell it could not close, a mesh that failed the certificate) are the
/// engine's, not the input's: the trace is tried on other line grids, then the lattice path meshes the molecule.
bool trace_failed(const mesh_params& params, const result<mesh_output>& out) {
  return params.method == mesh_method::trace && !out && out.error().code() == errc::internal_error;
}

/// run_pipeline, adding its wall seconds to `failed_seconds` when it fails.
result<mesh_output> timed_attempt(const molecule& mol, const mesh_params& params, const mesh_limits& limits,
                                  const line_grid_offset& line_offset, progress_token& progress,
                                  double& failed_seconds) {
  const auto start = std::chrono::steady_clock::now();
  result<mesh_output> out = run_pipeline(mol, params, limits, line_offset, progress);
  if (!out) failed_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

/// params.method on its own, then for a trace job that fails inside the engine: the other line grids in turn, and
/// at last the lattice path (mesh_output::fallback_reason), every failed attempt's time counted.
result<mesh_output> mesh_with_fallbacks(const molecule& mol, const mesh_params& params, const mesh_limits& limits,
                                        progress_token& progress) {
  double failed_seconds = 0;
  result<mesh_output> out = timed_attempt(mol, params, limits, trace_line_grids[0], progress, failed_seconds);
  std::size_t retries = 0;
  while (trace_failed(params, out) && retries + 1 < trace_line_grids.size()) {
    ++retries;
    out = timed_attempt(mol, params, limits, trace_line_grids[retries], progress, failed_seconds);
  }
  if (trace_failed(params, out)) {
    const std::string trace_error = out.error().message();
    mesh_params lattice_params = params;
    lattice_params.method = mesh_method::lattice;
    out = timed_attempt(mol, lattice_params, limits, {}, progress, failed_seconds);
    if (!out && out.error().code() == errc::internal_error) {
      return status{errc::internal_error, trace_error + "; the lattice path: " + out.error().message()};
    }
    if (!out) return out;
    out->method = params.method;
    out->fallback_reason =
        trace_error + " (the last of " + std::to_string(trace_line_grids.size()) + " line grids tried)";
  }
  if (!out) return out;
  out->trace.grid_retries = retries;
  out->failed_attempt_seconds = failed_seconds;
  return out;
}

}  // namespace

const char* method_name(mesh_method method) noexcept {
  return method == mesh_method::trace ? "trace" : "lattice";
}

const char* refine_name(refine_mode refine) noexcept { return refine == refine_mode::full ? "full" : "none"; }

const char* cavity_mode_name(cavity_mode cavities) noexcept {
  return cavities == cavity_mode::drop ? "drop" : "keep";
}

bool parse_cavity_mode(std::string_view name, cavity_mode& out) noexcept {
  if (name == "keep") return out = cavity_mode::keep, true;
  if (name == "drop") return out = cavity_mode::drop, true;
  return false;
}

bool parse_method(std::string_view name, mesh_method& out) noexcept {
  if (name == "trace") return out = mesh_method::trace, true;
  if (name == "lattice") return out = mesh_method::lattice, true;
  return false;
}

bool parse_refine(std::string_view name, refine_mode& out) noexcept {
  if (name == "full") return out = refine_mode::full, true;
  if (name == "none") return out = refine_mode::none, true;
  return false;
}

status validate(const mesh_params& params) {
  using r = parameter_ranges;
  const auto check = [](const char* name, double value, double lo, double hi) -> status {
    if (!std::isfinite(value) || value < lo || value > hi) {
      return {errc::invalid_argument, std::string(name) + " must be a number in [" + format_number(lo) + ", " +
                                          format_number(hi) + "], got " + format_number(value)};
    }
    return {};
  };
  if (status s = check("density", params.density, r::min_density, r::max_density); !s) return s;
  if (status s = check("d", params.d, r::min_d, r::max_d); !s) return s;
  if (status s = check("t0", params.t0, r::min_t0, r::max_t0); !s) return s;
  const trace_parameters& t = params.trace;
  if (status s = check("trace_degree", t.legendre_degree, r::min_legendre_degree, r::max_legendre_degree); !s) return s;
  if (status s = check("trace_step", t.step_fraction, r::min_trace_step_fraction, r::max_trace_step_fraction); !s) {
    return s;
  }
  if (status s = check("trace_cos_bound", t.cos_bound, r::min_trace_cos_bound, r::max_trace_cos_bound); !s) return s;
  return check("trace_extreme_tolerance", t.extreme_tolerance, r::min_extreme_tolerance, r::max_extreme_tolerance);
}

result<mesh_output> mesh_molecule(const molecule& mol, const mesh_params& params, const mesh_limits& limits,
                                  progress_token& progress) {
  if (status s = validate(params); !s) return s;
  if (mol.atoms.size() > limits.max_atoms) {
    return status{errc::limit_exceeded, std::to_string(mol.atoms.size()) + " atoms exceed the limit of " +
                                            std::to_string(limits.max_atoms)};
  }
  const int threads = params.threads == 0 ? tbb::task_arena::automatic : static_cast<int>(params.threads);
  tbb::task_arena arena(threads);
  result<mesh_output> out = status{errc::internal_error, "not run"};
  arena.execute([&] {
    if (status s = check_atom_resolution(mol, params, progress); !s) {
      out = s;
      return;
    }
    out = mesh_with_fallbacks(mol, params, limits, progress);
  });
  return out;
}

}  // namespace tracemesh
