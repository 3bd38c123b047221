#pragma once
/// @file mesher.hpp
/// The one entry point of the engine: atoms + parameters → a certified surface mesh and its report.
/// Used identically by the `tracemesh` command and the `tracemeshd` service.

#include <string>
#include <string_view>
#include <vector>

#include "core/limits.hpp"
#include "core/mesh.hpp"
#include "core/analysis/mesh_analysis.hpp"
#include "core/molecule.hpp"
#include "core/progress.hpp"
#include "core/stage_clock.hpp"
#include "core/status.hpp"
#include "core/trace/trace_parameters.hpp"

namespace tracemesh {

/// How surface points are connected into polygons.
enum class mesh_method {
  trace,    ///< the paper's: roots on x-parallel lines (eq. 6), traced contours (Algorithm 1), polygons (Algorithm 2)
  lattice,  ///< roots on the edges of a tetrahedral lattice, polygons by marching tetrahedra
};
/// What happens to the polygons' triangles before the certificate.
enum class refine_mode {
  none,  ///< the triangulated polygons as they are (trace), or the marching-tetrahedra triangles (lattice)
  full,  ///< the quality pass (remesh.hpp)
};
/// What happens to components enclosed by another component (inner cavities, and anything inside them; see
/// analysis/enclosure.hpp).
enum class cavity_mode {
  keep,  ///< every component is delivered (the report flags the enclosed ones)
  drop,  ///< enclosed components are removed before the certificate: only the outer surfaces are delivered
};
/// Stable names ("trace", "lattice"; "none", "full"; "keep", "drop") used by the CLI, the service and the report.
const char* method_name(mesh_method method) noexcept;
const char* refine_name(refine_mode refine) noexcept;
const char* cavity_mode_name(cavity_mode cavities) noexcept;
/// Parses those names; false (and `out` unchanged) for anything else.
bool parse_method(std::string_view name, mesh_method& out) noexcept;
bool parse_refine(std::string_view name, refine_mode& out) noexcept;
bool parse_cavity_mode(std::string_view name, cavity_mode& out) noexcept;

/// Per-job parameters (ranges in parameter_ranges).
struct mesh_params {
  double density = 1.0;  ///< requested vertices per Å² (sets the sampling step h̃ ≈ 1/√density)
  double d = -1.0;       ///< kernel decay rate, < 0
  double t0 = 1.0;       ///< isovalue, > 0
  /// trace: certified on the whole ladder, within 1.25× of the lattice path's time (README
  /// "Benchmarks", the default rule).
  mesh_method method = mesh_method::trace;
  refine_mode refine = refine_mode::full;
  cavity_mode cavities = cavity_mode::keep;
  trace_parameters trace;  ///< used by mesh_method::trace only
  unsigned threads = 0;  ///< worker threads; 0 = all cores. Never changes the output.
};

/// errc::invalid_argument naming the parameter when one is NaN or outside its range.
status validate(const mesh_params& params);

struct mesh_output {
  surface_mesh mesh;
  mesh_report report;
  std::vector<stage_timing> timings;
  std::size_t atoms_meshed = 0;        ///< atoms with radius > 0
  std::size_t zero_radius_atoms = 0;   ///< atoms skipped because their radius is 0
  double max_surface_distance = 0;     ///< max over vertices of |φ(v) − t0| / |∇φ(v)|, Å
  double field_cutoff_error = 0;       ///< bound on |φ_cutoff − φ| relative to t0 (see gaussian_field.hpp)
  /// report.topologically_certified(), max_surface_distance ≤ 1e-3 Å and, for a mesh of the trace path, no folded
  /// triangle (report.folded_triangles; mesher.cpp says why the lattice path's may have some).
  bool certified = false;
  mesh_method method = mesh_method::trace;    ///< as requested
  /// Why the trace path gave way to the lattice path (its internal_error: a cell it could not close, or a mesh that
  /// failed the certificate); empty when it did not. `trace` then holds nothing (method_used()).
  std::string fallback_reason;
  /// Wall seconds of the attempts whose mesh was not delivered (trace attempts on other line grids, the trace before
  /// a lattice fallback); `timings` are the delivered attempt's.
  double failed_attempt_seconds = 0;
  refine_mode refine = refine_mode::full;     ///< as requested
  cavity_mode cavities = cavity_mode::keep;   ///< as requested
  /// cavity_mode::drop: the enclosed components removed (before the certificate), and their triangles.
  std::size_t dropped_components = 0;
  std::size_t dropped_triangles = 0;
  trace_stats trace;                   ///< filled by mesh_method::trace
};

/// The path whose polygons `out.mesh` holds: `requested` (out.method, or the parameters a report echoes), or lattice
/// when the trace path fell back.
inline mesh_method method_used(mesh_method requested, const mesh_output& out) {
  return out.fallback_reason.empty() ? requested : mesh_method::lattice;
}

/// Meshes the Gaussian surface {φ = t0} of `mol`. Deterministic: the same input gives the same mesh whatever
/// params.threads is. A trace job that ends in internal_error is traced again on other line grids
/// (trace_stats::grid_retries), then meshed by the lattice path, and the output says so (method_used,
/// fallback_reason; failed_attempt_seconds): a user gets a certified mesh of any molecule the engine can mesh, and
/// never a lattice mesh labelled as a traced one. Errors: invalid_argument (params), nothing_to_mesh (no atom with
/// radius > 0), limit_exceeded (extent or size over `limits`), unresolvable_input (an atom below
/// parameter_ranges::min_atom_surface_radius_per_edge, see atom_resolution.hpp), cancelled (token),
/// internal_error (certificate failed, on the lattice path too for a trace job).
result<mesh_output> mesh_molecule(const molecule& mol, const mesh_params& params, const mesh_limits& limits,
                                  progress_token& progress);

/// The engine's version: part of every job id and report, so that a change to the meshes it makes never serves a
/// mesh cached by an older engine. Bump it whenever delivered meshes change; CHANGELOG.md says what each changed.
inline constexpr const char* engine_version = "tracemesh-engine-24";

}  // namespace tracemesh
