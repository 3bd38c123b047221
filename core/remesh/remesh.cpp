#include "core/remesh/remesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <vector>

#include "core/mesh_edits/short_edge_collapse.hpp"
#include "core/remesh/remesh_chunks.hpp"
#include "core/remesh/remesh_geometry.hpp"
#include "core/remesh/remesh_patch.hpp"
#include "core/remesh/remesh_small_components.hpp"

namespace tracemesh {
namespace {

/// The final collapses may take a component down to this many vertices (a tetrahedron).
constexpr std::uint32_t smallest_collapsed_component = 4;

template <class Body>
void parallel_over(std::size_t count, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) body(i);
  });
}

double surface_area(const surface_mesh& mesh) {
  double twice = 0;
  for (const auto& t : mesh.triangles) {
    twice += norm(detail::area_vector(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]));
  }
  return twice / 2;
}

}  // namespace

result<remesh_stats> remesh_surface(surface_mesh& mesh, const gaussian_field& field, const remesh_options& options,
                                    progress_token& progress) {
  if (status s = detail::check_remesh_options(options); !s) return s;
  if (!progress.report(mesh_stage::refining, 0.0)) return status{errc::cancelled, "remesh: cancelled"};
  const double l = options.target_edge;
  const double expected_triangles = 4 * surface_area(mesh) / (std::sqrt(3.0) * l * l);
  if (expected_triangles > static_cast<double>(options.max_triangles)) {
    return status{errc::limit_exceeded, "remesh: the target edge length would give more than max_triangles triangles"};
  }
  std::vector<vec3> input_normals;
  const bool trusted = options.trust_input_normals && mesh.normals.size() == mesh.positions.size();
  const std::size_t normal_evaluations = trusted ? 0 : mesh.positions.size();
  if (!trusted) {
    input_normals.resize(mesh.positions.size());
    parallel_over(mesh.positions.size(),
                  [&](std::size_t v) { input_normals[v] = detail::field_normal(field, mesh.positions[v]); });
    input_normals.swap(mesh.normals);
  }
  remesh_stats stats;
  if (!mesh.triangles.empty() || !mesh.positions.empty()) {
    result<remesh_stats> done = detail::remesh_in_chunks(mesh, field, options, progress);
    if (!done) return done.error();
    stats = done.value();
  }
  stats.field_evaluations += normal_evaluations;
  mesh.atom_index.clear();  // the caller's to fill (the mesher does, with the certificate's field probe)
  stats.remade_components = detail::resample_small_components(mesh, field, l);
  // After the remakes: a small cavity whose remake the certificate's tests refused (a thin wall to another sheet,
  // which its new faces would cross) may still lose its short edges, down to a tetrahedron.
  stats.final_collapses = collapse_short_edges(mesh, 0, options.final_collapse_below * l, smallest_collapsed_component,
                                               blocked_links::flipped);
  return stats;
}

}  // namespace tracemesh
