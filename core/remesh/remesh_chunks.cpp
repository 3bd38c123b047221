#include "core/remesh/remesh_chunks.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/remesh/remesh_mesh.hpp"
#include "core/remesh/remesh_patch.hpp"

namespace tracemesh::detail {
namespace {

/// Smaller chunks balance better over the threads; much smaller ones have more seams to redo.
constexpr std::int64_t cells_per_chunk = 12;
/// Where cells grow beyond their natural size (make_grid), a chunk holds fewer of them, so that it stays about
/// chunk_edges·L wide, but never fewer than this: grown patches of one colour stay 2·6 − (6 + 2) = 4 cells apart,
/// and a patch that fails a round redoes a small part of the mesh.
constexpr std::int64_t min_cells_per_chunk = 6;
/// A chunk's patch reaches this many cells beyond it; its context this many more.
constexpr std::int64_t patch_growth = 1;
constexpr std::int64_t context_growth = 1;
/// A patch's vertices this many rings or more from its boundary, and not frozen, are done: later patches that reach
/// them keep them frozen instead of remeshing them again (they only need to remesh the band along their boundary).
constexpr int boundary_rings = 3;
/// Cell coordinates take 21 bits per axis so that a cell packs into 64 bits.
constexpr int coordinate_bits = 21;
constexpr std::int64_t max_coordinate = (std::int64_t{1} << coordinate_bits) - 1;

using cell = std::array<std::int64_t, 3>;

/// Every directed edge a→b appears once and b→a once too (closed, edge-manifold, consistently oriented), every
/// vertex is used. (Each patch checks its vertices' fans when it is built.)
status validate_closed(const surface_mesh& mesh) {
  const std::size_t n = mesh.positions.size();
  if (status s = check_mesh_arrays(n, mesh.normals.size(), mesh.triangles); !s) return s;
  std::vector<std::uint32_t> begin(n + 1, 0);
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t v : t) ++begin[v + 1];
  }
  for (std::size_t v = 0; v < n; ++v) {
    if (begin[v + 1] == 0) return invalid_mesh("has an unreferenced vertex");
    begin[v + 1] += begin[v];
  }
  std::vector<std::uint32_t> targets(begin.back());
  std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
  for (const auto& t : mesh.triangles) {
    for (int i = 0; i < 3; ++i) targets[fill[t[i]]++] = t[(i + 1) % 3];
  }
  const auto count = [&](std::uint32_t from, std::uint32_t to) {
    return std::count(targets.begin() + begin[from], targets.begin() + begin[from + 1], to);
  };
  std::atomic<bool> repeated{false}, open{false};
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, static_cast<std::uint32_t>(n)), [&](const auto& range) {
    for (std::uint32_t a = range.begin(); a != range.end(); ++a) {
      for (std::uint32_t k = begin[a]; k < begin[a + 1]; ++k) {
        const std::uint32_t b = targets[k];
        if (count(a, b) != 1) repeated = true;
        if (count(b, a) != 1) open = true;
      }
    }
  });
  if (repeated) return invalid_mesh("has a non-manifold or inconsistently oriented edge");
  if (open) return invalid_mesh("is not closed (boundary edge)");
  return status::success();
}

/// The cubic cells that chunks are made of, numbered from a corner below every vertex.
class cell_grid {
 public:
  cell_grid(const vec3& origin, double size, std::int64_t chunk_cells)
      : origin_(origin), size_(size), chunk_cells_(chunk_cells) {}
  double size() const { return size_; }
  /// Cells along a chunk's edge.
  std::int64_t chunk_cells() const { return chunk_cells_; }
  cell of(const vec3& p) const {
    cell c{};
    for (int axis = 0; axis < 3; ++axis) {
      c[axis] = std::clamp(static_cast<std::int64_t>(std::floor((p[axis] - origin_[axis]) / size_)), std::int64_t{0},
                           max_coordinate);
    }
    return c;
  }
  /// The box of cells [lo, hi) per axis.
  box3 box(const cell& lo, const cell& hi) const {
    box3 b;
    for (int axis = 0; axis < 3; ++axis) {
      b.lo[axis] = origin_[axis] + static_cast<double>(lo[axis]) * size_;
      b.hi[axis] = origin_[axis] + static_cast<double>(hi[axis]) * size_;
    }
    return b;
  }
  static std::uint64_t key(const cell& c) {
    return (static_cast<std::uint64_t>(c[0]) << (2 * coordinate_bits)) |
           (static_cast<std::uint64_t>(c[1]) << coordinate_bits) | static_cast<std::uint64_t>(c[2]);
  }

 private:
  vec3 origin_;
  double size_;
  std::int64_t chunk_cells_;
};

/// The mesh being remeshed: the caller's arrays, triangles replaced by patches marked dead until the end, and the
/// triangles of every cell (by centroid at creation; a triangle outside a patch never moves).
class chunked_mesh {
 public:
  /// Input triangles with an edge longer than half a cell are long: they stay out of every patch (see make_grid).
  chunked_mesh(surface_mesh& mesh, const cell_grid& grid) : mesh_(mesh), grid_(grid), long_edge_(grid.size() / 2) {
    alive_.assign(mesh.triangles.size(), 0);
    cell_keys_.assign(mesh.triangles.size(), 0);
    incident_.assign(mesh.positions.size(), 0);
    done_.assign(mesh.positions.size(), 0);
    live_triangles_ = mesh.triangles.size();
    for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
      if (is_long(t)) {
        alive_[t] = 1;
        for (const std::uint32_t v : mesh.triangles[t]) ++incident_[v];
        long_triangles_.push_back(t);
      } else {
        enter(t);
      }
    }
  }

  const cell_grid& grid() const { return grid_; }
  std::size_t live_triangles() const { return live_triangles_; }

  /// The chunks holding a triangle's centroid, in key order.
  std::vector<cell> chunks() const {
    std::vector<std::uint64_t> keys;
    for (const auto& [key, triangles] : cells_) {
      const cell c = unpack(key);
      const std::int64_t n = grid_.chunk_cells();
      keys.push_back(cell_grid::key({c[0] / n, c[1] / n, c[2] / n}));
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    std::vector<cell> out;
    for (const std::uint64_t k : keys) out.push_back(unpack(k));
    return out;
  }

  /// The live triangles with their centroid in the cells [lo, hi) and not in [skip_lo, skip_hi), sorted.
  std::vector<std::uint32_t> triangles_in(const cell& lo, const cell& hi, const cell& skip_lo,
                                          const cell& skip_hi) const {
    std::vector<std::uint32_t> out;
    for (std::int64_t x = std::max<std::int64_t>(lo[0], 0); x < hi[0]; ++x) {
      for (std::int64_t y = std::max<std::int64_t>(lo[1], 0); y < hi[1]; ++y) {
        for (std::int64_t z = std::max<std::int64_t>(lo[2], 0); z < hi[2]; ++z) {
          const bool skipped = x >= skip_lo[0] && x < skip_hi[0] && y >= skip_lo[1] && y < skip_hi[1] &&
                               z >= skip_lo[2] && z < skip_hi[2];
          if (skipped) continue;
          const std::uint64_t key = cell_grid::key({x, y, z});
          const auto it = cells_.find(key);
          if (it == cells_.end()) continue;
          // Entries are not removed when their triangle is (see leave): skip the stale ones.
          for (const std::uint32_t t : it->second) {
            if (alive_[t] && cell_keys_[t] == key) out.push_back(t);
          }
        }
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());  // a slot reused in the same cell is listed twice
    return out;
  }

  /// The patch of the chunk `chunk` and its context; `vertices` receives the patch's vertex indices (in order of
  /// first use: local index = position), `triangles` its triangle indices (sorted), `boundary` whether each vertex
  /// has triangles outside. `scratch` is the caller's (one per thread): all no_index, left so.
  void extract(const cell& chunk, remesh_patch_input& patch, remesh_patch_context& context,
               std::vector<std::uint32_t>& vertices, std::vector<std::uint32_t>& triangles,
               std::vector<std::uint8_t>& boundary, std::vector<std::uint32_t>& scratch) const {
    cell lo{}, hi{}, outer_lo{}, outer_hi{};
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = chunk[axis] * grid_.chunk_cells() - patch_growth;
      hi[axis] = (chunk[axis] + 1) * grid_.chunk_cells() + patch_growth;
      outer_lo[axis] = lo[axis] - context_growth;
      outer_hi[axis] = hi[axis] + context_growth;
    }
    if (scratch.size() < mesh_.positions.size()) scratch.resize(mesh_.positions.size(), no_index);
    // scratch[v]: v's local index while extracting.
    const auto local = [&](std::uint32_t v, std::vector<std::uint32_t>& list) {
      if (scratch[v] == no_index) {
        scratch[v] = static_cast<std::uint32_t>(list.size());
        list.push_back(v);
      }
      return scratch[v];
    };
    triangles = triangles_in(lo, hi, hi, hi);
    vertices.clear();
    patch.triangles.resize(triangles.size());
    for (std::size_t k = 0; k < triangles.size(); ++k) {
      for (int i = 0; i < 3; ++i) patch.triangles[k][i] = local(mesh_.triangles[triangles[k]][i], vertices);
    }
    const std::size_t n = vertices.size();
    patch.positions.resize(n);
    patch.normals.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      patch.positions[i] = mesh_.positions[vertices[i]];
      patch.normals[i] = mesh_.normals[vertices[i]];
    }
    std::vector<std::uint32_t> uses(n, 0);
    for (const auto& t : patch.triangles) {
      for (const std::uint32_t v : t) ++uses[v];
    }
    // Vertices with triangles outside the patch are on its boundary (remesh_mesh finds most of them by their open
    // edges; this also catches a vertex whose fan the patch cuts without cutting any of its edges' both faces).
    boundary.assign(n, 0);
    patch.frozen.assign(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      boundary[i] = uses[i] < incident_[vertices[i]];
      patch.frozen[i] = boundary[i] || done_[vertices[i]];
    }

    // The context: the fixed triangles that meet the reach box. Every one has its centroid in the context's cells,
    // since triangles there are shorter than half a cell, or is long (see make_grid).
    const box3 patch_box = grid_.box(lo, hi);
    const double margin = grid_.size() / 2;
    context.bounded = true;
    context.reach = {patch_box.lo - vec3{margin, margin, margin}, patch_box.hi + vec3{margin, margin, margin}};
    context.triangles.clear();
    std::vector<std::uint32_t> all = vertices;  // then the context vertices outside the patch
    std::vector<std::uint32_t> fixed = triangles_in(outer_lo, outer_hi, lo, hi);
    for (const std::uint32_t t : long_triangles_) {
      if (alive_[t]) fixed.push_back(t);
    }
    for (const std::uint32_t t : fixed) {
      const auto& tri = mesh_.triangles[t];
      if (!context.reach.meets(bounds_of(mesh_.positions, tri))) continue;
      context.triangles.push_back({local(tri[0], all), local(tri[1], all), local(tri[2], all)});
    }
    context.positions.resize(all.size() - n);
    for (std::size_t i = n; i < all.size(); ++i) context.positions[i - n] = mesh_.positions[all[i]];
    for (const std::uint32_t v : all) scratch[v] = no_index;
  }

  /// Replaces the patch's triangles by its output (see remesh_patch_output) and marks the output vertices flagged
  /// in `done` (see done_vertices) done.
  void merge(const std::vector<std::uint32_t>& vertices, const std::vector<std::uint32_t>& triangles,
             const std::vector<std::uint8_t>& done, const remesh_patch_output& out) {
    // Slots of removed triangles and vertices are reused (last freed, first taken): the arrays never grow past
    // the input's size by much, where appending would double their capacity.
    for (const std::uint32_t t : triangles) leave(t);
    live_triangles_ -= triangles.size();
    std::vector<std::uint8_t> kept(vertices.size(), 0);
    for (const std::uint32_t o : out.origin) {
      if (o != no_index) kept[o] = 1;
    }
    for (std::size_t i = 0; i < vertices.size(); ++i) {
      if (!kept[i]) free_vertices_.push_back(vertices[i]);
    }
    std::vector<std::uint32_t> global(out.mesh.positions.size());
    for (std::size_t v = 0; v < global.size(); ++v) {
      global[v] = out.origin[v] != no_index ? vertices[out.origin[v]] : new_vertex();
      mesh_.positions[global[v]] = out.mesh.positions[v];
      mesh_.normals[global[v]] = out.mesh.normals[v];
    }
    for (std::size_t v = 0; v < global.size(); ++v) done_[global[v]] |= done[v];
    for (const auto& t : out.mesh.triangles) {
      const std::uint32_t slot = new_triangle();
      mesh_.triangles[slot] = {global[t[0]], global[t[1]], global[t[2]]};
      enter(slot);
    }
    live_triangles_ += out.mesh.triangles.size();
  }

  /// Drops dead triangles and the vertices no triangle uses, keeping the order of the rest.
  void compact() {
    std::vector<std::uint32_t> index(mesh_.positions.size(), no_index);
    std::uint32_t kept = 0;
    for (std::uint32_t v = 0; v < index.size(); ++v) {
      if (incident_[v] == 0) continue;
      index[v] = kept;
      mesh_.positions[kept] = mesh_.positions[v];
      mesh_.normals[kept] = mesh_.normals[v];
      incident_[kept] = incident_[v];
      done_[kept] = done_[v];
      ++kept;
    }
    mesh_.positions.resize(kept);
    mesh_.normals.resize(kept);
    incident_.resize(kept);
    done_.resize(kept);
    std::size_t kept_triangles = 0;
    for (std::size_t t = 0; t < mesh_.triangles.size(); ++t) {
      if (!alive_[t]) continue;
      const auto& old = mesh_.triangles[t];
      mesh_.triangles[kept_triangles++] = {index[old[0]], index[old[1]], index[old[2]]};
    }
    mesh_.triangles.resize(kept_triangles);
    mesh_.triangles.shrink_to_fit();
    alive_.assign(kept_triangles, 1);
    cells_.clear();
    cell_keys_.clear();
    long_triangles_.clear();
  }

 private:
  static cell unpack(std::uint64_t key) {
    return {static_cast<std::int64_t>(key >> (2 * coordinate_bits)),
            static_cast<std::int64_t>((key >> coordinate_bits) & max_coordinate),
            static_cast<std::int64_t>(key & max_coordinate)};
  }
  std::uint64_t cell_key_of(std::uint32_t t) const {
    const auto& tri = mesh_.triangles[t];
    const vec3 centroid = (mesh_.positions[tri[0]] + mesh_.positions[tri[1]] + mesh_.positions[tri[2]]) / 3.0;
    return cell_grid::key(grid_.of(centroid));
  }
  void enter(std::uint32_t t) {
    alive_[t] = 1;
    for (const std::uint32_t v : mesh_.triangles[t]) ++incident_[v];
    cell_keys_[t] = cell_key_of(t);
    cells_[cell_keys_[t]].push_back(t);
  }
  bool is_long(std::uint32_t t) const {
    const auto& tri = mesh_.triangles[t];
    for (int i = 0; i < 3; ++i) {
      if (distance(mesh_.positions[tri[i]], mesh_.positions[tri[(i + 1) % 3]]) > long_edge_) return true;
    }
    return false;
  }
  /// The triangle's entry stays in its cell (finding it there costs more than skipping it later): triangles_in
  /// skips entries whose triangle is dead or whose slot now holds a triangle of another cell. A live triangle's
  /// vertices have not moved since it entered (only a patch holding it moves them, and then it leaves first), so its
  /// centroid still finds its cell.
  void leave(std::uint32_t t) {
    alive_[t] = 0;
    for (const std::uint32_t v : mesh_.triangles[t]) --incident_[v];
    free_triangles_.push_back(t);
  }
  std::uint32_t new_vertex() {
    if (!free_vertices_.empty()) {
      const std::uint32_t v = free_vertices_.back();
      free_vertices_.pop_back();
      incident_[v] = 0;
      done_[v] = 0;
      return v;
    }
    mesh_.positions.emplace_back();
    mesh_.normals.emplace_back();
    incident_.push_back(0);
    done_.push_back(0);
    return static_cast<std::uint32_t>(mesh_.positions.size() - 1);
  }
  std::uint32_t new_triangle() {
    if (!free_triangles_.empty()) {
      const std::uint32_t t = free_triangles_.back();
      free_triangles_.pop_back();
      return t;
    }
    mesh_.triangles.emplace_back();
    alive_.push_back(0);
    cell_keys_.push_back(0);
    return static_cast<std::uint32_t>(mesh_.triangles.size() - 1);
  }

  surface_mesh& mesh_;
  cell_grid grid_;
  std::vector<std::uint8_t> alive_;
  /// Per triangle slot: the cell its triangle entered (a slot reused by a triangle of another cell leaves a stale
  /// entry in the first cell, which this tells apart without recomputing the centroid).
  std::vector<std::uint64_t> cell_keys_;
  std::vector<std::uint32_t> incident_;
  std::vector<std::uint8_t> done_;
  std::vector<std::uint32_t> free_vertices_, free_triangles_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
  double long_edge_;
  std::vector<std::uint32_t> long_triangles_;  ///< input triangles kept out of the cells, never in a patch
  std::size_t live_triangles_ = 0;
};

/// Cells of chunk_edges·L / cells_per_chunk (and at least twice the longest edge the quality pass leaves unsplit),
/// grown to twice the longest triangle edge but at most to twice that natural size, and few enough per axis for the
/// packed keys; chunks of as many cells as keep them chunk_edges·L wide (at least min_cells_per_chunk). A context of
/// one cell then holds every triangle that may meet a patch, but for the triangles with an edge longer than half a
/// cell: those stay out of every patch, as they are, and join every context they reach.
/// Such edges are the trace path's few long triangulation diagonals, whose triangles face away from the surface
/// normals, so that the quality pass could not split them anyway. Cells grown without that cap make few, large
/// patches, and a patch that fails a round then redoes much of the mesh.
constexpr double max_cell_growth = 2;

cell_grid make_grid(const surface_mesh& mesh, const remesh_options& options) {
  const box3 bounds = bounds_of(mesh.positions);
  double longest_edge = 0;
  for (const auto& t : mesh.triangles) {
    for (int i = 0; i < 3; ++i) {
      longest_edge = std::max(longest_edge, distance(mesh.positions[t[i]], mesh.positions[t[(i + 1) % 3]]));
    }
  }
  const double l = options.target_edge;
  const double natural = std::max(options.chunk_edges * l / cells_per_chunk, 2 * options.split_above * l);
  double size = std::clamp(2 * longest_edge, natural, max_cell_growth * natural);
  for (int axis = 0; axis < 3; ++axis) {
    size = std::max(size, (bounds.hi[axis] - bounds.lo[axis]) / static_cast<double>(max_coordinate - 4));
  }
  const auto chunk_cells = std::clamp(static_cast<std::int64_t>(std::lround(cells_per_chunk * natural / size)),
                                      min_cells_per_chunk, cells_per_chunk);
  // Two cells of room below every vertex: patches and contexts of the first chunks reach there.
  return cell_grid(bounds.lo - vec3{2 * size, 2 * size, 2 * size}, size, chunk_cells);
}

/// The output vertices of a patch that are done: neither frozen nor within boundary_rings rings of its boundary.
std::vector<std::uint8_t> done_vertices(const remesh_patch_output& out, const std::vector<std::uint8_t>& boundary) {
  std::vector<std::uint8_t> near(out.mesh.positions.size(), 0);
  for (std::size_t v = 0; v < near.size(); ++v) near[v] = out.origin[v] != no_index && boundary[out.origin[v]];
  for (int ring = 0; ring < boundary_rings; ++ring) {
    std::vector<std::uint8_t> grown = near;
    for (const auto& t : out.mesh.triangles) {
      if (near[t[0]] || near[t[1]] || near[t[2]]) grown[t[0]] = grown[t[1]] = grown[t[2]] = 1;
    }
    near.swap(grown);
  }
  for (std::size_t v = 0; v < near.size(); ++v) near[v] = !near[v] && !out.frozen[v];
  return near;
}

void add_stats(remesh_stats& total, const remesh_stats& s) {
  total.splits += s.splits;
  total.collapses += s.collapses;
  total.flips += s.flips;
  total.relaxations += s.relaxations;
  total.rejected_ops += s.rejected_ops;
  total.frozen_vertices += s.frozen_vertices;
  total.field_evaluations += s.field_evaluations;
  total.rounds = std::max(total.rounds, s.rounds);
  total.unchanged_patches += s.input_returned ? 1 : 0;
  ++total.patches;
}

}  // namespace

result<remesh_stats> remesh_in_chunks(surface_mesh& mesh, const gaussian_field& field, const remesh_options& options,
                                      progress_token& progress) {
  if (status s = validate_closed(mesh); !s) return s;
  const status cancelled{errc::cancelled, "remesh: cancelled"};
  remesh_stats total;
  if (mesh.triangles.size() < options.single_patch_triangles) {
    remesh_patch_input whole{std::move(mesh.positions), std::move(mesh.normals), std::move(mesh.triangles), {}};
    result<remesh_patch_output> out = remesh_patch(whole, {}, field, options, progress, true);
    if (!out) {
      mesh.positions = std::move(whole.positions);
      mesh.normals = std::move(whole.normals);
      mesh.triangles = std::move(whole.triangles);
      return out.error();
    }
    add_stats(total, out->stats);
    total.input_returned = out->stats.input_returned;
    total.unchecked = out->stats.unchecked;
    mesh.positions = std::move(out->mesh.positions);
    mesh.normals = std::move(out->mesh.normals);
    mesh.triangles = std::move(out->mesh.triangles);
    return total;
  }

  chunked_mesh chunks(mesh, make_grid(mesh, options));
  const std::vector<cell> all_chunks = chunks.chunks();
  std::atomic<std::size_t> done{0};
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> scratches;
  status failure = status::success();
  for (int colour = 0; colour < 8 && failure.ok(); ++colour) {
    std::vector<cell> batch;
    for (const cell& c : all_chunks) {
      if ((c[0] & 1) == (colour & 1) && (c[1] & 1) == ((colour >> 1) & 1) && (c[2] & 1) == ((colour >> 2) & 1)) {
        batch.push_back(c);
      }
    }
    struct patch_job {
      std::vector<std::uint32_t> vertices, triangles;
      std::vector<std::uint8_t> boundary, done;
      result<remesh_patch_output> out = status{errc::cancelled, "remesh: cancelled"};
    };
    std::vector<patch_job> jobs(batch.size());
    tbb::parallel_for(std::size_t{0}, batch.size(), [&](std::size_t k) {
      if (progress.cancelled()) return;
      std::vector<std::uint32_t>& scratch = scratches.local();
      remesh_patch_input patch;
      remesh_patch_context context;
      chunks.extract(batch[k], patch, context, jobs[k].vertices, jobs[k].triangles, jobs[k].boundary, scratch);
      if (patch.triangles.empty()) {
        jobs[k].out = remesh_patch_output{};
        return;
      }
      jobs[k].out = remesh_patch(patch, context, field, options, progress);
      if (jobs[k].out) jobs[k].done = done_vertices(jobs[k].out.value(), jobs[k].boundary);
      const double fraction = static_cast<double>(++done) / static_cast<double>(all_chunks.size());
      progress.report(mesh_stage::refining, fraction);
    });
    for (patch_job& job : jobs) {
      if (!job.out) {
        failure = job.out.error();
        break;
      }
      if (job.triangles.empty()) continue;
      add_stats(total, job.out->stats);
      if (!job.out->stats.input_returned) chunks.merge(job.vertices, job.triangles, job.done, job.out.value());
      if (chunks.live_triangles() > options.max_triangles) {
        failure = status{errc::limit_exceeded, "remesh: more than max_triangles triangles"};
        break;
      }
    }
    if (progress.cancelled()) failure = cancelled;
  }
  chunks.compact();
  total.input_returned = total.patches == total.unchanged_patches;
  if (!failure) return failure;
  return total;
}

}  // namespace tracemesh::detail
