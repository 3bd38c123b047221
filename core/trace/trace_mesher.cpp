#include "core/trace/trace_mesher.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <string>

#include "core/mesh_edits/short_edge_collapse.hpp"
#include "core/trace/cell_polygons.hpp"
#include "core/trace/line_roots.hpp"
#include "core/trace/loop_triangulation.hpp"
#include "core/trace/strip_arcs.hpp"
#include "core/trace/trace_lines.hpp"
#include "core/trace/untouched_cavities.hpp"

namespace tracemesh {
namespace {

/// h̃ = line_spacing_at_unit_density / √density. The paper: h̃ = 1.0 Å ≈ 1 vertex/Å², 0.7 Å ≈ 2. With arc points
/// a little further apart than the lines (below), 0.93 Å gives the raw mesh the density asked for (0.97–1.03 and
/// 1.93–1.98 v/Å² over the ladder) and better raw triangles (docs/method.md#line-spacing-and-arc-point-spacing).
constexpr double line_spacing_at_unit_density = 0.93;
/// Kept interior points of an arc are about this × h̃ apart (docs/method.md#long-arcs-are-resampled asks for
/// ≤ 1.5 h̃): the raw edge-ratio mean is at least 0.70 on every ladder row from 1.12 to 1.18 (0.69 on `gly` at 1.0).
constexpr double resample_spacing_factor = 1.15;
/// A root where |φ_x| is below this × |∇φ| is a tangency of its line (a double root), not a crossing…
constexpr double tangent_tolerance = 1e-6;
/// …and so are two neighbouring roots of opposite φ_x where |φ_x| is below tangent_pair_slope × |∇φ|, when they are
/// closer than tangent_pair_gap × h̃ or the cap they bound is at most tangent_cap_height × h̃ high: the line grazes
/// the surface, which bulges across it by ~slope × gap / 4 (a parabola of curvature κ across the line has slope
/// κ·gap/2 at its roots and height κ·gap²/8). Meshing such a cap takes a lens of four vertices whose two middle
/// points are about its height apart: triangles of mÅ edges, degenerate to the certificate, on 2buk_capsid (the gap
/// rule), and an edge of 5e-5 Å on 1k4r_capsid at 1 v/Å² (roots 0.023 Å apart, the cap rule), which the quality
/// pass left where it had to freeze the region and which no Draco grid could keep apart. The mesh misses the cap by
/// its height, far below the chord error of an edge of h̃.
constexpr double tangent_pair_slope = 0.05;
constexpr double tangent_pair_gap = 1e-2;
constexpr double tangent_cap_height = 1e-4;
/// Raw edges at an arc point shorter than this × h̃ are welded (short_edge_collapse.hpp): 0.01 Å at 1 v/Å², where a
/// Draco grid's step is 0.01 Å at most and 0.6 mÅ after the four extra bits it may take.
constexpr double weld_below = 1e-2;
/// When the polygons' triangles are delivered as they are (refine=none; not the paper's), raw edges at an arc point
/// shorter than this × the arcs' point spacing are collapsed as well, the arc point going. Where a line meets the
/// surface at a grazing angle, the first points of its xy and xz arcs leave the root in nearly the same direction
/// and lie close together, in thin triangles that kept the raw edge-ratio mean under 0.70 (docs/method.md:
/// 0.687 → 0.706 on mache at 1 v/Å²; swept from 0.3 to 0.6). Not before the quality pass, whose own collapses do
/// the same: from the collapsed mesh it gained nothing and ran a second round on mache at 2 v/Å² (0.21 → 0.41 s).
constexpr double raw_collapse_below = 0.5;
/// How far apart the traced points of a raw mesh are (Å).
struct point_spacing {
  double resample = 0;        ///< the interior points an arc keeps are about this far apart
  double collapse_below = 0;  ///< edges at an arc point shorter than this are collapsed (0: only the welds)
};

using index_range = tbb::blocked_range<std::size_t>;

status cancelled_status() { return {errc::cancelled, "meshing was cancelled"}; }

/// True when two roots `gap` Å apart whose steeper slope |φ_x| / |∇φ| is `slope` bound a cap too small to mesh (see
/// tangent_pair_gap and tangent_cap_height).
bool grazing_cap(double gap, double slope, double h) {
  return gap < tangent_pair_gap * h || slope * gap / 4 <= tangent_cap_height * h;
}

/// A line tangent to the surface only touches it: its double root (or a pair of roots closer than the root solver
/// can tell apart, with φ_x ≈ 0 and opposite signs) is not a crossing, no arc starts or ends there, and the contour
/// passes by on one side of the line. Such roots are left out, in pairs so that the line keeps its parity.
std::vector<line_point> without_tangencies(const std::vector<line_point>& roots, double h) {
  const auto slope = [](const line_point& p) { return std::abs(p.gradient.x) / norm(p.gradient); };
  std::vector<line_point> kept;
  for (std::size_t q = 0; q < roots.size(); ++q) {
    if (slope(roots[q]) <= tangent_tolerance) continue;
    const bool pair = q + 1 < roots.size() && slope(roots[q]) < tangent_pair_slope &&
                      slope(roots[q + 1]) < tangent_pair_slope && roots[q].gradient.x * roots[q + 1].gradient.x < 0 &&
                      grazing_cap(roots[q + 1].x - roots[q].x, std::max(slope(roots[q]), slope(roots[q + 1])), h);
    if (pair) {
      ++q;  // both go
      continue;
    }
    kept.push_back(roots[q]);
  }
  return kept;
}

/// Roots on the lines of every block (eq. 6), with the field's gradient at each (the traces start from it). With
/// `dips` (not null), also the lines' dips towards t0 (untouched_cavities.hpp), in block order.
result<trace_lines> find_all_line_roots(const gaussian_field& field, const lattice& lat,
                                        const std::vector<lattice_index>& blocks, int degree,
                                        std::vector<vec3>* dips, progress_token& progress, trace_stats& stats) {
  std::vector<std::vector<trace_lines::entry>> per_block(blocks.size());
  std::vector<std::vector<vec3>> dips_per_block(dips ? blocks.size() : 0);
  std::vector<line_root_stats> block_stats(blocks.size());
  std::atomic<std::size_t> done{0};
  line_root_settings settings;
  settings.degree = degree;
  if (dips) settings.dip_ratio = untouched_cavity_settings{}.dip_ratio;
  // One finder per thread, copied from one whose tables (quadrature, Legendre → Bernstein) are computed once: made
  // per range, they took 3% of fas2's run time. A finder's results do not depend on its history.
  tbb::enumerable_thread_specific<line_root_finder> finders{line_root_finder(settings)};
  tbb::parallel_for(index_range(0, blocks.size(), 4), [&](const index_range& r) {
    if (progress.cancelled()) return;
    std::vector<std::uint32_t> atoms;
    block_line_roots roots;
    line_root_finder& finder = finders.local();
    for (std::size_t n = r.begin(); n != r.end(); ++n) {
      const lattice_index& b = blocks[n];
      field.atoms_near_box(lat.block_box(b), atoms);
      finder.find(field, lat, b, atoms, roots, block_stats[n]);
      const double h = lat.spacing();
      for (int k = 0; k < lattice::block_cells; ++k) {
        for (int j = 0; j < lattice::block_cells; ++j) {
          const int line = j + lattice::block_cells * k;
          const line_id id{b.j * lattice::block_cells + j, b.k * lattice::block_cells + k};
          std::vector<line_point> points;
          for (std::uint32_t q = roots.first[line]; q < roots.first[line + 1]; ++q) {
            const vec3 p{roots.roots[q].x, static_cast<double>(id.j) * h, static_cast<double>(id.k) * h};
            line_point point{roots.roots[q].x, {}};
            field.value_and_gradient(p, point.gradient);
            ++block_stats[n].field_evaluations;
            points.push_back(point);
          }
          for (const line_point& point : without_tangencies(points, h)) per_block[n].push_back({id, point});
        }
      }
      for (const block_line_roots::dip& dip : roots.dips) {
        const std::int64_t j = b.j * lattice::block_cells + dip.line % lattice::block_cells;
        const std::int64_t k = b.k * lattice::block_cells + dip.line / lattice::block_cells;
        dips_per_block[n].push_back({dip.x, static_cast<double>(j) * h, static_cast<double>(k) * h});
      }
    }
    progress.report(mesh_stage::roots, static_cast<double>(done += r.size()) / static_cast<double>(blocks.size()));
  });
  if (progress.cancelled()) return cancelled_status();
  std::vector<trace_lines::entry> entries;
  for (std::size_t n = 0; n < blocks.size(); ++n) {
    stats.lines += block_stats[n].lines;
    stats.proven_lines += block_stats[n].proven_lines;
    stats.polynomial_roots += block_stats[n].polynomial_roots;
    stats.bracketed_roots += block_stats[n].bracketed_roots;
    stats.tangent_root_intervals += block_stats[n].tangent_intervals;
    stats.field_evaluations += block_stats[n].field_evaluations;
    entries.insert(entries.end(), per_block[n].begin(), per_block[n].end());
    if (dips) dips->insert(dips->end(), dips_per_block[n].begin(), dips_per_block[n].end());
  }
  return trace_lines(std::move(entries));
}

/// Algorithm 1 on every strip.
status trace_all_strips(const gaussian_field& field, const strip_settings& settings, traced_surface& surface,
                        progress_token& progress, trace_stats& stats) {
  std::vector<strip_id> strips = strips_beside(surface.lines);
  std::vector<strip_trace> traces(strips.size());
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(index_range(0, strips.size(), 16), [&](const index_range& r) {
    if (progress.cancelled()) return;
    for (std::size_t s = r.begin(); s != r.end(); ++s) {
      traces[s] = trace_strip(field, surface.lines, strips[s], settings);
    }
    progress.report(mesh_stage::tracing, static_cast<double>(done += r.size()) / static_cast<double>(strips.size()));
  });
  if (progress.cancelled()) return cancelled_status();
  for (const strip_trace& trace : traces) stats.field_evaluations += trace.evaluations;
  surface.strips = std::move(strips);
  surface.traces = std::move(traces);
  return {};
}

/// Numbers the strips' interior points after the roots.
void number_interior_points(traced_surface& surface, trace_stats& stats) {
  surface.interior_first.resize(surface.traces.size());
  std::uint32_t next = static_cast<std::uint32_t>(surface.lines.root_count());
  for (std::size_t s = 0; s < surface.traces.size(); ++s) {
    const strip_trace& t = surface.traces[s];
    surface.interior_first[s] = next;
    next += static_cast<std::uint32_t>(t.interior.size());
    stats.arcs += t.arcs.size();
    stats.extreme_points += t.extreme_points;
    stats.untangled_points += t.untangled_points;
    stats.retraced_arcs += t.retraced;
    stats.level_shifted_strips += t.level_shifted;
  }
}

/// The two cells beside each strip that holds an arc, sorted.
std::vector<cell_id> cells_of(const traced_surface& surface) {
  std::vector<cell_id> cells;
  for (std::size_t s = 0; s < surface.strips.size(); ++s) {
    if (surface.traces[s].arcs.empty()) continue;
    const strip_id& st = surface.strips[s];
    cells.push_back({st.j - (st.orientation != 0), st.k - (st.orientation == 0)});
    cells.push_back({st.j, st.k});
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  return cells;
}

/// Renumbers the vertices in the order the triangles (cell by cell) first use them, so that a triangle's corners are
/// close in memory. Numbered as assembled (all roots, then every strip's points), a triangle's corners lay 1.9·10⁵
/// indices apart on average on 2buk_capsid at 2 v/Å² (2·10³ once renumbered; 1·10⁴ in the lattice path's refined
/// mesh), and every later stage that walks the mesh (quality pass, certificate, encoders) paid in cache misses.
/// Vertices no triangle uses keep their order after the others (the certificate reports them).
void number_vertices_by_first_use(surface_mesh& mesh) {
  constexpr std::uint32_t unnumbered = ~std::uint32_t{0};
  std::vector<std::uint32_t> number(mesh.positions.size(), unnumbered);
  std::uint32_t next = 0;
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t v : t) {
      if (number[v] == unnumbered) number[v] = next++;
    }
  }
  for (std::uint32_t& n : number) {
    if (n == unnumbered) n = next++;
  }
  std::vector<vec3> positions(mesh.positions.size()), normals(mesh.normals.size());
  for (std::size_t v = 0; v < number.size(); ++v) {
    positions[number[v]] = mesh.positions[v];
    normals[number[v]] = mesh.normals[v];
  }
  mesh.positions.swap(positions);
  mesh.normals.swap(normals);
  for (auto& t : mesh.triangles) {
    for (std::uint32_t& v : t) v = number[v];
  }
}

/// Gives the chords of each wall and of each line to one of the cells beside it (cell_mesh::wall_chords,
/// line_chords). Algorithm 2 triangulates each cell's polygons on their own, which is sound only under the
/// admissibility rule. The strategies that drop the wall rule (for a sheet lying almost in a wall) lay triangles in the
/// wall between its arcs; where the surface crosses the wall there as a thin tube, both cells beside it do, on the
/// same vertices, and an edge they share carries four triangles. Admissible triangles of different cells meet only
/// along shared arcs (docs/method.md#the-admissibility-rule); that holds again once no wall, and no line, has chords
/// from two cells. The cell beyond a wall (+y or +z) keeps its own chords, and the cell before it, when both made
/// some, is meshed again with the rule kept on that wall; of two diagonal cells that both made chords along the
/// line between them, the one at the lower j keeps the rule on its +y wall. A cell meshed again may make chords in
/// another of its walls, so the check is repeated; each time, it keeps the rule on one more of its two +y and +z
/// walls, so the pass ends.
void give_chords_to_one_cell(const gaussian_field& field, const traced_surface& surface,
                             const std::vector<cell_id>& ids, std::vector<cell_mesh>& cells) {
  const auto find = [&](const cell_id& c) {
    const auto it = std::lower_bound(ids.begin(), ids.end(), c);
    return it != ids.end() && *it == c ? static_cast<std::size_t>(it - ids.begin()) : ids.size();
  };
  // A wall or line of this cell (its bit in wall_chords or line_chords), the other cell beside it (at dj, dk), the
  // same wall or line's bit in that cell, and the wall on which this cell keeps the rule when both have chords there.
  struct facing_chords {
    bool line;
    std::uint8_t mine;
    std::int64_t dj, dk;
    std::uint8_t theirs, kept;
  };
  constexpr std::array<facing_chords, 4> pairs{{
      {false, wall_y_high, 1, 0, wall_y_low, wall_y_high},
      {false, wall_z_high, 0, 1, wall_z_low, wall_z_high},
      {true, 1u << 3, 1, 1, 1u << 0, wall_y_high},  // line (j + 1, k + 1): the other's line (0, 0)
      {true, 1u << 1, 1, -1, 1u << 2, wall_y_high},  // line (j + 1, k): the other's line (0, 1)
  }};
  std::vector<std::uint8_t> kept(cells.size(), 0);
  for (;;) {
    std::vector<std::size_t> again;
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const std::uint8_t before = kept[c];
      for (const facing_chords& p : pairs) {
        if (((p.line ? cells[c].line_chords : cells[c].wall_chords) & p.mine) == 0) continue;
        const std::size_t n = find({ids[c].j + p.dj, ids[c].k + p.dk});
        if (n == ids.size() || ((p.line ? cells[n].line_chords : cells[n].wall_chords) & p.theirs) == 0) continue;
        kept[c] |= p.kept;
      }
      if (kept[c] != before) again.push_back(c);
    }
    if (again.empty()) return;
    for (const std::size_t c : again) {
      const std::size_t spent = cells[c].evaluations;
      cells[c] = mesh_cell(field, surface, ids[c], kept[c]);
      cells[c].evaluations += spent;
    }
  }
}

/// The mesh: roots, then interior points, then the cells' Steiner points; triangles cell by cell.
surface_mesh assemble(const traced_surface& surface, std::vector<cell_mesh>& cells) {
  surface_mesh mesh;
  const auto add = [&](const vec3& position, const vec3& gradient) {
    mesh.positions.push_back(position);
    mesh.normals.push_back(normalized(-gradient));
  };
  const double h = surface.spacing;
  for (std::size_t n = 0; n < surface.lines.line_count(); ++n) {
    const line_id& id = surface.lines.id(n);
    for (const line_point& p : surface.lines.roots(n)) {
      add({p.x, static_cast<double>(id.j) * h, static_cast<double>(id.k) * h}, p.gradient);
    }
  }
  for (const strip_trace& t : surface.traces) {
    for (const surface_sample& p : t.interior) add(p.position, p.gradient);
  }
  for (cell_mesh& cell : cells) {
    const auto first_steiner = static_cast<std::uint32_t>(mesh.positions.size());
    for (const surface_sample& p : cell.steiner) add(p.position, p.gradient);
    for (auto t : cell.triangles) {
      for (auto& v : t) {
        if (v >= steiner_vertex) v = first_steiner + (v - steiner_vertex);
      }
      mesh.triangles.push_back(t);
    }
    std::vector<std::array<std::uint32_t, 3>>().swap(cell.triangles);
  }
  return mesh;
}

/// The triangulated polygons of the blocks (the body of mesh_trace_blocks), their points spaced as `points` says;
/// with `seeds` (not null), the lines' dips are stored there for the search for untouched cavities.
result<surface_mesh> mesh_polygons(const gaussian_field& field, const gaussian_field& walk_field, const lattice& lat,
                                   const std::vector<lattice_index>& blocks, const trace_parameters& params,
                                   const point_spacing& points, std::vector<vec3>* seeds, progress_token& progress,
                                   stage_clock& clock, trace_stats& stats, trace_lines& lines_out) {
  const double h = lat.spacing();
  stats.line_spacing = h;
  stats.step = params.step_fraction * h;
  auto lines = find_all_line_roots(field, lat, blocks, params.legendre_degree, seeds, progress, stats);
  if (!lines) return lines.error();
  if (lines->root_count() == 0) return status{errc::nothing_to_mesh, "no point of the surface φ = t0 was found"};
  clock.finish(mesh_stage::roots);

  traced_surface surface;
  surface.spacing = h;
  surface.lines = std::move(*lines);
  strip_settings settings;
  settings.spacing = h;
  settings.max_step = stats.step;
  settings.cos_bound = params.cos_bound;
  settings.extreme_tolerance = params.extreme_tolerance;
  settings.resample_spacing = points.resample;
  settings.walk_field = &walk_field;
  if (status s = trace_all_strips(field, settings, surface, progress, stats); !s) return s;
  number_interior_points(surface, stats);
  clock.finish(mesh_stage::tracing);

  const std::vector<cell_id> cell_ids = cells_of(surface);
  std::vector<cell_mesh> cells(cell_ids.size());
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(index_range(0, cell_ids.size(), 64), [&](const index_range& r) {
    if (progress.cancelled()) return;
    for (std::size_t c = r.begin(); c != r.end(); ++c) cells[c] = mesh_cell(field, surface, cell_ids[c]);
    progress.report(mesh_stage::triangulating,
                    static_cast<double>(done += r.size()) / static_cast<double>(cell_ids.size()));
  });
  if (progress.cancelled()) return cancelled_status();
  give_chords_to_one_cell(field, surface, cell_ids, cells);
  std::size_t open_cells = 0, intersecting_cells = 0, failures = 0;
  for (std::size_t s = 0; s < surface.traces.size(); ++s) failures += surface.traces[s].failures;
  for (const cell_mesh& c : cells) {
    stats.polygons += c.loops;
    stats.fallback_loops += c.fallback_loops;
    stats.field_evaluations += c.evaluations;
    open_cells += !c.closed;
    intersecting_cells += c.intersecting;
  }
  surface_mesh mesh = assemble(surface, cells);
  const auto first_arc_point = static_cast<std::uint32_t>(surface.lines.root_count());
  lines_out = std::move(surface.lines);
  if (open_cells > 0 || intersecting_cells > 0 || failures > 0) {
    return status{errc::internal_error, "trace polygons could not be closed: " + std::to_string(failures) +
                                            " roots without an arc, " + std::to_string(open_cells) +
                                            " cells with an open or untriangulable loop, " +
                                            std::to_string(intersecting_cells) + " cells with intersecting triangles"};
  }
  // Never a root: every line point stays a vertex (Algorithm 2).
  stats.welded_edges += collapse_short_edges(mesh, first_arc_point, weld_below * h);
  if (points.collapse_below > 0) {
    flip_to_short_diagonals(mesh, first_arc_point, points.collapse_below);
    stats.collapsed_raw_edges += collapse_short_edges(mesh, first_arc_point, points.collapse_below);
  }
  return mesh;
}

/// The cavity in `cavity`'s box, meshed by the trace path on the box's own grid (its line through the minimum
/// guarantees roots): the atoms whose cutoff reaches the box, moved so that the box starts at the origin, give φ
/// inside the box, and the box's faces hold no surface, so every polygon closes inside it. Its points are spaced as
/// `points` says.
result<surface_mesh> mesh_untouched_cavity(const gaussian_field& field, const untouched_cavity& cavity,
                                           const trace_parameters& params, const point_spacing& points,
                                           trace_stats& stats) {
  std::vector<std::uint32_t> near;
  field.atoms_near_box(cavity.box, near);
  molecule local;
  for (const std::uint32_t k : near) {
    const gaussian_field::atom_data a = field.atom_at(k);
    local.atoms.push_back({vec3{a.x, a.y, a.z} - cavity.box.lo, 1 / std::sqrt(a.inv_r2), 0});
  }
  const gaussian_field local_field(local, field.d(), field.t0());
  const lattice lat(cavity.spacing, {0, 0, 0});
  std::vector<lattice_index> blocks;
  for (int i = 0; i < cavity.blocks_x; ++i) {
    for (int j = 0; j < cavity.blocks_yz; ++j) {
      for (int k = 0; k < cavity.blocks_yz; ++k) blocks.push_back({i, j, k});
    }
  }
  std::vector<stage_timing> timings;
  stage_clock clock(timings);
  progress_token progress;  // the job's token is polled between cavities; this one keeps the job's stages in order
  trace_stats local_stats;
  trace_lines lines;
  auto mesh = mesh_polygons(local_field, local_field, lat, blocks, params, points, nullptr, progress, clock,
                            local_stats, lines);
  stats.field_evaluations += local_stats.field_evaluations;
  stats.fallback_loops += local_stats.fallback_loops;
  if (!mesh) return mesh;
  for (vec3& p : mesh->positions) {
    p += cavity.box.lo;
    if (!cavity.box.contains(p)) return status{errc::internal_error, "an untouched cavity's mesh left its box"};
  }
  stats.welded_edges += local_stats.welded_edges;  // the piece's own, now that it is kept
  return mesh;
}

/// Appends `piece` (its own vertices and triangles) to `mesh`.
void append(surface_mesh& mesh, const surface_mesh& piece) {
  const auto offset = static_cast<std::uint32_t>(mesh.positions.size());
  mesh.positions.insert(mesh.positions.end(), piece.positions.begin(), piece.positions.end());
  mesh.normals.insert(mesh.normals.end(), piece.normals.begin(), piece.normals.end());
  for (auto t : piece.triangles) {
    for (std::uint32_t& v : t) v += offset;
    mesh.triangles.push_back(t);
  }
}

/// Finds the cavities no line touched (untouched_cavities.hpp) and appends their meshes. A cavity whose local trace
/// fails is left out (the mesh stays closed without it) and counted. Their short edges are not collapsed for
/// delivery (raw_collapse_below): a void a few Å² in area, meshed on a grid finer than h̃, would lose a third of it.
status add_untouched_cavities(const gaussian_field& field, const trace_lines& lines, double h,
                              const std::vector<vec3>& seeds, const trace_parameters& params,
                              progress_token& progress, surface_mesh& mesh, trace_stats& stats) {
  untouched_cavity_stats search;
  const std::vector<untouched_cavity> cavities =
      find_untouched_cavities(field, lines, h, seeds, untouched_cavity_settings{}, progress, search);
  stats.field_evaluations += search.field_evaluations;
  for (const untouched_cavity& cavity : cavities) {
    if (progress.cancelled()) return cancelled_status();
    // Arc points as far apart as on the job's own lines, so that the void gets about the job's density; if that
    // trace fails, the local grid's own spacing.
    auto piece = mesh_untouched_cavity(field, cavity, params, {resample_spacing_factor * h}, stats);
    if (!piece) piece = mesh_untouched_cavity(field, cavity, params, {resample_spacing_factor * cavity.spacing}, stats);
    if (!piece) {
      ++stats.untouched_cavities_left;
      continue;
    }
    append(mesh, *piece);
    ++stats.untouched_cavities;
  }
  return progress.cancelled() ? cancelled_status() : status{};
}

}  // namespace

double trace_line_spacing(double density) { return line_spacing_at_unit_density / std::sqrt(density); }

result<surface_mesh> mesh_trace_blocks(const gaussian_field& field, const gaussian_field& walk_field,
                                       const lattice& lat, const std::vector<lattice_index>& blocks,
                                       const trace_parameters& params, bool delivered_as_is, const mesh_limits& limits,
                                       progress_token& progress, stage_clock& clock, trace_stats& stats) {
  std::vector<vec3> seeds;
  trace_lines lines;
  const double resample = resample_spacing_factor * lat.spacing();
  const point_spacing points{resample, delivered_as_is ? raw_collapse_below * resample : 0.0};
  auto mesh = mesh_polygons(field, walk_field, lat, blocks, params, points, &seeds, progress, clock, stats, lines);
  if (!mesh) return mesh;
  if (status s = add_untouched_cavities(field, lines, lat.spacing(), seeds, params, progress, *mesh, stats); !s) {
    return s;
  }
  number_vertices_by_first_use(*mesh);
  // The polygons' own counts, whatever was collapsed for delivery: each collapse took one vertex and two triangles.
  stats.raw_vertices = mesh->positions.size() + stats.collapsed_raw_edges;
  stats.raw_triangles = mesh->triangles.size() + 2 * stats.collapsed_raw_edges;
  if (mesh->triangles.size() > limits.max_triangles) {
    return status{errc::limit_exceeded, "mesh has " + std::to_string(mesh->triangles.size()) + " triangles (limit " +
                                            std::to_string(limits.max_triangles) + ")"};
  }
  clock.finish(mesh_stage::triangulating);
  return mesh;
}

}  // namespace tracemesh
