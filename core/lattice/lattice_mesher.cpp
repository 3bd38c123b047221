#include "core/lattice/lattice_mesher.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <limits>
#include <string>
#include <tuple>

#include "core/analysis/analysis_local_folds.hpp"
#include "core/lattice/edge_root.hpp"
#include "core/lattice/lattice_sampler.hpp"
#include "core/lattice/marching_tetrahedra.hpp"
#include "core/mesh_edits/short_edge_collapse.hpp"
#include "core/release_memory.hpp"

namespace tracemesh {
namespace {

status cancelled_status() { return {errc::cancelled, "meshing was cancelled"}; }

/// A polygon corner kept as its edge's place in the block, ((di·n + dj)·n + dk)·7 + direction with n = block_points:
/// the edges of a block's cubes start at its n³ lattice points. 16 bits instead of a 64-bit key (a million-atom
/// capsid has 15 million polygons, held until every root is known).
using block_edge = std::uint16_t;
constexpr int edge_direction_count = 7;
static_assert(block_points * block_points * block_points * edge_direction_count <= 65536);

std::uint64_t block_key(const lattice& lat, const lattice_index& block) {
  return lat.edge_key({block.i * lattice::block_cells, block.j * lattice::block_cells, block.k * lattice::block_cells},
                      0);
}

/// Keys are linear in their fields (lattice::edge_key_offset), so an edge's key less its block's splits into them.
block_edge block_edge_of(std::uint64_t key, std::uint64_t first_key) {
  constexpr std::uint64_t mask = (1ULL << 20) - 1;
  const std::uint64_t offset = key - first_key;
  const std::uint64_t di = (offset >> 43) & mask, dj = (offset >> 23) & mask, dk = (offset >> 3) & mask;
  return static_cast<block_edge>(((di * block_points + dj) * block_points + dk) * edge_direction_count + (offset & 7));
}

std::uint64_t edge_key_of(block_edge edge, std::uint64_t first_key) {
  const int direction = edge % edge_direction_count, point = edge / edge_direction_count;
  const int dk = point % block_points, dj = (point / block_points) % block_points, di = point / (block_points * block_points);
  return first_key + lattice::edge_key_offset(di, dj, dk, direction);
}

/// What one block contributes: its polygons and the roots on the cut edges it owns.
struct block_output {
  std::vector<std::array<block_edge, 3>> triangles;
  std::vector<std::array<block_edge, 4>> quads;  ///< cyclic order; split later along the shorter diagonal
  std::vector<edge_vertex> roots;  ///< sorted by key; emptied once they are in the mesh
  std::vector<std::uint64_t> keys;  ///< the roots' keys, kept to find them by
};

template <std::size_t corners>
void store_polygons(const std::vector<std::array<std::uint64_t, corners>>& polygons, std::uint64_t first_key,
                    std::vector<std::array<block_edge, corners>>& out) {
  out.resize(polygons.size());
  for (std::size_t p = 0; p < polygons.size(); ++p) {
    for (std::size_t c = 0; c < corners; ++c) out[p][c] = block_edge_of(polygons[p][c], first_key);
  }
}

/// Samples every block, meshes it and solves its roots (in block order: deterministic).
result<std::vector<block_output>> process_blocks(const gaussian_field& field, const lattice& lat,
                                                 const std::vector<lattice_index>& blocks, progress_token& progress) {
  std::vector<block_output> outputs(blocks.size());
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks.size(), 4), [&](const tbb::blocked_range<std::size_t>& r) {
    if (progress.cancelled()) return;
    std::vector<std::uint32_t> atoms;
    std::vector<double> values;
    block_polygons polygons;
    for (std::size_t n = r.begin(); n != r.end(); ++n) {
      field.atoms_near_box(lat.block_box(blocks[n]), atoms);
      sample_block(field, lat, blocks[n], atoms, values);
      polygons.clear();
      triangulate_block(lat, blocks[n], values, field.t0(), polygons);
      const std::uint64_t first_key = block_key(lat, blocks[n]);
      store_polygons(polygons.triangles, first_key, outputs[n].triangles);
      store_polygons(polygons.quads, first_key, outputs[n].quads);
      std::vector<edge_vertex>& roots = outputs[n].roots;
      solve_block_roots(field, lat, blocks[n], atoms, values, roots);
      std::sort(roots.begin(), roots.end(), [](const edge_vertex& a, const edge_vertex& b) { return a.key < b.key; });
      roots.shrink_to_fit();
    }
    const std::size_t finished = done += r.size();
    progress.report(mesh_stage::sampling, static_cast<double>(finished) / blocks.size());
  });
  if (progress.cancelled()) return cancelled_status();
  return outputs;
}

/// Puts the roots into the mesh block by block (vertex = the block's first vertex + the root's rank in its block)
/// and keeps only their keys, freeing each block's roots as it goes: no array of every root is ever made (a
/// million-atom capsid has ten million). Returns each block's first vertex.
std::vector<std::uint32_t> number_vertices(std::vector<block_output>& outputs, surface_mesh& mesh) {
  std::vector<std::uint32_t> first(outputs.size() + 1, 0);
  for (std::size_t n = 0; n < outputs.size(); ++n) {
    first[n + 1] = first[n] + static_cast<std::uint32_t>(outputs[n].roots.size());
  }
  mesh.positions.resize(first.back());
  mesh.normals.resize(first.back());
  tbb::parallel_for(std::size_t{0}, outputs.size(), [&](std::size_t n) {
    std::vector<edge_vertex>& roots = outputs[n].roots;
    outputs[n].keys.resize(roots.size());
    for (std::size_t r = 0; r < roots.size(); ++r) {
      outputs[n].keys[r] = roots[r].key;
      mesh.positions[first[n] + r] = roots[r].position;
      mesh.normals[first[n] + r] = roots[r].normal;
    }
    std::vector<edge_vertex>().swap(roots);
  });
  return first;
}

/// For each block, the index of the block that owns the edges starting on its upper faces, per combination of
/// faces (bit 0: +i, 1: +j, 2: +k; entry 0 is the block itself); no_block where culling dropped it.
constexpr std::uint32_t no_block = std::numeric_limits<std::uint32_t>::max();

std::vector<std::array<std::uint32_t, 8>> upper_neighbours(const std::vector<lattice_index>& blocks) {
  const auto before = [](const lattice_index& a, const lattice_index& b) {
    return std::tie(a.i, a.j, a.k) < std::tie(b.i, b.j, b.k);
  };
  std::vector<std::array<std::uint32_t, 8>> neighbours(blocks.size());
  tbb::parallel_for(std::size_t{0}, blocks.size(), [&](std::size_t n) {
    for (int bits = 0; bits < 8; ++bits) {
      const lattice_index b{blocks[n].i + (bits & 1), blocks[n].j + ((bits >> 1) & 1), blocks[n].k + ((bits >> 2) & 1)};
      const auto it = std::lower_bound(blocks.begin(), blocks.end(), b, before);
      const bool found = it != blocks.end() && it->i == b.i && it->j == b.j && it->k == b.k;
      neighbours[n][static_cast<std::size_t>(bits)] = found ? static_cast<std::uint32_t>(it - blocks.begin()) : no_block;
    }
  });
  return neighbours;
}

/// The index of `key` in the sorted `keys`, or keys.size() when absent. Branch-free halving: the comparisons of
/// these searches are unpredictable, and a mispredicted branch per step made std::lower_bound most of the cost of
/// assembling a capsid's 15 million triangles.
std::size_t rank_of(const std::vector<std::uint64_t>& keys, std::uint64_t key) {
  if (keys.empty()) return 0;
  const std::uint64_t* first = keys.data();
  for (std::size_t length = keys.size(); length > 1;) {
    const std::size_t half = length / 2;
    first = first[half] <= key ? first + half : first;  // the last key ≤ `key` stays in [first, first + length)
    length -= half;
  }
  return *first == key ? static_cast<std::size_t>(first - keys.data()) : keys.size();
}

using triangle_indices = std::array<std::uint32_t, 3>;

/// Whether either triangle faces against the vertex normals at all three corners (a fold, which the certificate
/// refuses). The two splits of a tetrahedron's quadrilateral lie in that tetrahedron and cut its faces alike, so
/// either keeps the mesh closed and free of intersections; only their folds tell them apart.
bool folds(const surface_mesh& mesh, const std::array<triangle_indices, 2>& split) {
  return detail::is_folded(mesh, split[0]) || detail::is_folded(mesh, split[1]);
}

/// Triangles from the block polygons; quadrilaterals split along their shorter diagonal (or the other, when only
/// that one does not fold). Each corner's vertex is
/// found in the block that owns its edge (the cube at the edge's lower end); false if that block holds no root there
/// (culling dropped a block with a cut edge: cannot happen, its bounds are conservative).
bool assemble_triangles(const lattice& lat, const std::vector<lattice_index>& blocks,
                        const std::vector<block_output>& outputs, const std::vector<std::uint32_t>& first_vertex,
                        const std::vector<vec3>& positions, surface_mesh& mesh) {
  const std::vector<std::array<std::uint32_t, 8>> neighbours = upper_neighbours(blocks);
  std::vector<std::size_t> offsets(outputs.size() + 1, 0);
  for (std::size_t n = 0; n < outputs.size(); ++n) {
    offsets[n + 1] = offsets[n] + outputs[n].triangles.size() + 2 * outputs[n].quads.size();
  }
  mesh.triangles.resize(offsets.back());
  std::atomic<bool> all_found{true};
  tbb::parallel_for(std::size_t{0}, outputs.size(), [&](std::size_t n) {
    const std::uint64_t first_key = block_key(lat, blocks[n]);
    const auto vertex = [&](block_edge e) -> std::uint32_t {
      const int point = e / edge_direction_count;
      const int dk = point % block_points, dj = (point / block_points) % block_points;
      const int di = point / (block_points * block_points);
      constexpr int top = lattice::block_cells;
      const std::uint32_t owner = neighbours[n][(di == top) | (dj == top) << 1 | (dk == top) << 2];
      if (owner == no_block) return all_found = false, 0;
      const std::vector<std::uint64_t>& keys = outputs[owner].keys;
      const std::size_t rank = rank_of(keys, edge_key_of(e, first_key));
      if (rank == keys.size()) return all_found = false, 0;
      return first_vertex[owner] + static_cast<std::uint32_t>(rank);
    };
    std::size_t out = offsets[n];
    for (const auto& t : outputs[n].triangles) mesh.triangles[out++] = {vertex(t[0]), vertex(t[1]), vertex(t[2])};
    for (const auto& q : outputs[n].quads) {
      std::array<std::uint32_t, 4> v{};
      for (int c = 0; c < 4; ++c) v[c] = vertex(q[c]);
      const std::array<triangle_indices, 2> along_02{{{v[0], v[1], v[2]}, {v[0], v[2], v[3]}}};
      const std::array<triangle_indices, 2> along_13{{{v[0], v[1], v[3]}, {v[1], v[2], v[3]}}};
      const bool shorter_02 =
          squared_norm(positions[v[0]] - positions[v[2]]) <= squared_norm(positions[v[1]] - positions[v[3]]);
      // The shorter diagonal, unless its split folds against the vertex normals and the other one does not.
      const bool folds_02 = folds(mesh, along_02), folds_13 = folds(mesh, along_13);
      const bool use_02 = folds_02 == folds_13 ? shorter_02 : !folds_02;
      for (const triangle_indices& t : use_02 ? along_02 : along_13) mesh.triangles[out++] = t;
    }
  });
  return all_found;
}

}  // namespace

result<surface_mesh> mesh_lattice_blocks(const gaussian_field& field, const lattice& lat,
                                         const std::vector<lattice_index>& blocks, const mesh_limits& limits,
                                         progress_token& progress, stage_clock& clock) {
  const std::uint64_t points = static_cast<std::uint64_t>(blocks.size()) * block_points * block_points * block_points;
  if (points > limits.max_lattice_points) {
    return status{errc::limit_exceeded, "surface needs " + std::to_string(points) + " lattice points (limit " +
                                            std::to_string(limits.max_lattice_points) + ")"};
  }
  auto outputs = process_blocks(field, lat, blocks, progress);
  if (!outputs) return outputs.error();
  clock.finish(mesh_stage::sampling);

  surface_mesh mesh;
  const std::vector<std::uint32_t> first_vertex = number_vertices(*outputs, mesh);
  if (mesh.positions.empty()) {
    return status{errc::nothing_to_mesh, "no point of the surface φ = t0 was found"};
  }
  clock.finish(mesh_stage::roots);

  const bool assembled = assemble_triangles(lat, blocks, *outputs, first_vertex, mesh.positions, mesh);
  outputs->clear();
  outputs->shrink_to_fit();
  release_freed_memory();
  if (!assembled) return status{errc::internal_error, "a cut lattice edge has no root (its block was culled)"};
  if (mesh.triangles.size() > limits.max_triangles) {
    return status{errc::limit_exceeded, "mesh has " + std::to_string(mesh.triangles.size()) + " triangles (limit " +
                                            std::to_string(limits.max_triangles) + ")"};
  }
  // Where a crevice is narrower than the lattice, tetrahedra cut it with triangles standing across it, against
  // the field normals at their corners: the certificate refuses such folds, so their edges are collapsed (every
  // vertex is a root on a lattice edge and may go).
  collapse_folded_triangles(mesh, 0);
  clock.finish(mesh_stage::triangulating);
  return mesh;
}

}  // namespace tracemesh
