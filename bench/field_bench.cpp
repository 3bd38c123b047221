// Micro-benchmarks of the mesher's front end on one real molecule, single-threaded so that numbers are per core:
// field construction, culling, block sampling, marching tetrahedra, edge roots, and the point evaluations the
// remesher calls (value_and_gradient, probe, project_to_surface) at points near the surface, and the trace path's
// line roots (with and without the bounds that prove spans root-free).
//
// Usage: field_bench [--molecule=FILE.pqr[.gz]] [--density=1] [benchmark flags...]
// Default molecule: ../shared/molecules/mache.pqr next to the source tree.
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/field/band_culling.hpp"
#include "core/lattice/edge_root.hpp"
#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice_sampler.hpp"
#include "core/lattice/marching_tetrahedra.hpp"
#include "core/io/pqr_reader.hpp"
#include "core/trace/line_roots.hpp"
#include "core/trace/trace_mesher.hpp"

namespace tracemesh {
namespace {

std::string molecule_file =
    (std::filesystem::path(__FILE__).parent_path() / "../../shared/molecules/mache.pqr").lexically_normal().string();
double density = 1.0;

/// Everything the benchmarks share, built once: the field, the lattice, the culled blocks, their sampled values
/// and atoms, and points near the surface (the edge roots, jittered by up to 0.05 Å).
struct front_end {
  molecule mol;
  std::unique_ptr<gaussian_field> field;
  std::unique_ptr<lattice> lat;
  std::vector<lattice_index> blocks;
  std::vector<std::vector<std::uint32_t>> block_atoms;
  std::vector<std::vector<double>> block_values;
  std::vector<vec3> surface_points;
};

/// Lattice as mesher.cpp builds it (spacing = target edge length; origin below every cutoff sphere).
lattice make_lattice(const gaussian_field& field) {
  const double spacing = std::sqrt(2.0 / (std::sqrt(3.0) * density));
  const double block = spacing * lattice::block_cells;
  const double margin = field.max_cutoff() + 2 * block;
  const auto index_floor = [&](double v) {
    return static_cast<std::int64_t>(std::floor(v / block)) * lattice::block_cells;
  };
  const box3& b = field.atom_bounds();
  return lattice(spacing, {index_floor(b.lo.x - margin), index_floor(b.lo.y - margin), index_floor(b.lo.z - margin)});
}

const front_end& shared_front_end() {
  static const std::unique_ptr<front_end> fe = [] {
    auto out = std::make_unique<front_end>();
    auto mol = read_pqr_file(molecule_file);
    if (!mol) {
      std::fprintf(stderr, "field_bench: %s: %s\n", molecule_file.c_str(), mol.error().message().c_str());
      std::exit(1);
    }
    out->mol = std::move(*mol);
    out->field = std::make_unique<gaussian_field>(out->mol, -1.0, 1.0);
    out->lat = std::make_unique<lattice>(make_lattice(*out->field));
    progress_token progress;
    out->blocks = std::move(*cull_blocks(*out->field, *out->lat, progress));
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> jitter(-0.05, 0.05);
    for (const lattice_index& block : out->blocks) {
      std::vector<std::uint32_t> atoms;
      std::vector<double> values;
      out->field->atoms_near_box(out->lat->block_box(block), atoms);
      sample_block(*out->field, *out->lat, block, atoms, values);
      std::vector<edge_vertex> roots;
      solve_block_roots(*out->field, *out->lat, block, atoms, values, roots);
      for (const edge_vertex& root : roots) {
        out->surface_points.push_back(root.position + vec3{jitter(rng), jitter(rng), jitter(rng)});
      }
      out->block_atoms.push_back(std::move(atoms));
      out->block_values.push_back(std::move(values));
    }
    std::fprintf(stderr, "field_bench: %s, %zu atoms, %zu blocks, %zu surface points\n", molecule_file.c_str(),
                 out->field->atom_count(), out->blocks.size(), out->surface_points.size());
    return out;
  }();
  return *fe;
}

/// The trace path's lattice (spacing h̃ for the density) and its culled blocks, built once.
struct trace_front_end {
  std::unique_ptr<lattice> lat;
  std::vector<lattice_index> blocks;
};

const trace_front_end& shared_trace_front_end() {
  static const std::unique_ptr<trace_front_end> fe = [] {
    const front_end& base = shared_front_end();
    auto out = std::make_unique<trace_front_end>();
    const double h = trace_line_spacing(density);
    const box3& b = base.field->atom_bounds();
    const double margin = base.field->max_cutoff() + 2 * h * lattice::block_cells;
    const auto index_floor = [&](double v) {
      return static_cast<std::int64_t>(std::floor(v / (h * lattice::block_cells))) * lattice::block_cells;
    };
    out->lat = std::make_unique<lattice>(
        h, lattice_index{index_floor(b.lo.x - margin), index_floor(b.lo.y - margin), index_floor(b.lo.z - margin)});
    progress_token progress;
    out->blocks = std::move(*cull_blocks(*base.field, *out->lat, progress));
    return out;
  }();
  return *fe;
}

/// Runs `work` in a one-thread arena: the numbers are per core.
template <class Work>
void single_threaded(Work&& work) {
  tbb::task_arena arena(1);
  arena.execute(work);
}

void field_construction(benchmark::State& state) {
  const front_end& fe = shared_front_end();
  for (auto _ : state) {
    gaussian_field field(fe.mol, -1.0, 1.0);
    benchmark::DoNotOptimize(field.atom_count());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.mol.atoms.size()));
}

void culling(benchmark::State& state) {
  const front_end& fe = shared_front_end();
  for (auto _ : state) {
    single_threaded([&] {
      progress_token progress;
      auto blocks = cull_blocks(*fe.field, *fe.lat, progress);
      benchmark::DoNotOptimize(blocks->size());
    });
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.blocks.size()));
}

void block_atoms(benchmark::State& state) {
  const front_end& fe = shared_front_end();
  std::vector<std::uint32_t> atoms;
  for (auto _ : state) {
    for (const lattice_index& block : fe.blocks) {
      fe.field->atoms_near_box(fe.lat->block_box(block), atoms);
      benchmark::DoNotOptimize(atoms.data());
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.blocks.size()));
}

void sampling(benchmark::State& state) {
  const front_end& fe = shared_front_end();
  std::vector<double> values;
  for (auto _ : state) {
    for (std::size_t n = 0; n < fe.blocks.size(); ++n) {
      sample_block(*fe.field, *fe.lat, fe.blocks[n], fe.block_atoms[n], values);
      benchmark::DoNotOptimize(values.data());
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.blocks.size()));
}

void triangulation(benchmark::State& state) {
  const front_end& fe = shared_front_end();
  block_polygons polygons;
  for (auto _ : state) {
    for (std::size_t n = 0; n < fe.blocks.size(); ++n) {
      polygons.clear();
      triangulate_block(*fe.lat, fe.blocks[n], fe.block_values[n], fe.field->t0(), polygons);
      benchmark::DoNotOptimize(polygons.triangles.data());
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.blocks.size()));
}

void edge_roots(benchmark::State& state) {
  const front_end& fe = shared_front_end();
  std::vector<edge_vertex> roots;
  for (auto _ : state) {
    for (std::size_t n = 0; n < fe.blocks.size(); ++n) {
      roots.clear();
      solve_block_roots(*fe.field, *fe.lat, fe.blocks[n], fe.block_atoms[n], fe.block_values[n], roots);
      benchmark::DoNotOptimize(roots.data());
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.surface_points.size()));
}

/// Per point: one call of `evaluate` for every surface point.
template <class Evaluate>
void per_surface_point(benchmark::State& state, Evaluate&& evaluate) {
  const front_end& fe = shared_front_end();
  for (auto _ : state) {
    for (const vec3& p : fe.surface_points) evaluate(*fe.field, p);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.surface_points.size()));
}

/// The roots of every culled block's 64 lines (line_root_finder); state.range(0): whether spans are first bounded
/// and the root-free ones skipped. Counters: field evaluations and spans proven root-free per block.
void trace_line_roots(benchmark::State& state) {
  const front_end& base = shared_front_end();
  const trace_front_end& fe = shared_trace_front_end();
  line_root_settings settings;
  settings.prove_root_free = state.range(0) != 0;
  line_root_finder finder(settings);
  std::vector<std::uint32_t> atoms;
  block_line_roots roots;
  line_root_stats stats;
  for (auto _ : state) {
    for (const lattice_index& block : fe.blocks) {
      base.field->atoms_near_box(fe.lat->block_box(block), atoms);
      finder.find(*base.field, *fe.lat, block, atoms, roots, stats);
      benchmark::DoNotOptimize(roots.roots.data());
    }
  }
  const auto blocks = static_cast<double>(state.iterations() * fe.blocks.size());
  state.counters["evaluations_per_block"] = static_cast<double>(stats.field_evaluations) / blocks;
  state.counters["proven_lines_per_block"] = static_cast<double>(stats.proven_lines) / blocks;
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fe.blocks.size()));
}

void point_value(benchmark::State& state) {
  per_surface_point(state, [](const gaussian_field& f, const vec3& p) { benchmark::DoNotOptimize(f.value(p)); });
}

void point_value_and_gradient(benchmark::State& state) {
  per_surface_point(state, [](const gaussian_field& f, const vec3& p) {
    vec3 g;
    benchmark::DoNotOptimize(f.value_and_gradient(p, g));
    benchmark::DoNotOptimize(g);
  });
}

void point_probe(benchmark::State& state) {
  per_surface_point(state, [](const gaussian_field& f, const vec3& p) { benchmark::DoNotOptimize(f.probe(p)); });
}

void point_dominant_atom(benchmark::State& state) {
  per_surface_point(state,
                    [](const gaussian_field& f, const vec3& p) { benchmark::DoNotOptimize(f.dominant_atom(p)); });
}

void point_projection(benchmark::State& state) {
  per_surface_point(state, [](const gaussian_field& f, const vec3& p) {
    vec3 q = p;
    benchmark::DoNotOptimize(f.project_to_surface(q, 0.5));
    benchmark::DoNotOptimize(q);
  });
}

}  // namespace
}  // namespace tracemesh

int main(int argc, char** argv) {
  // Our own flags first; the rest goes to Google Benchmark.
  std::vector<char*> rest{argv[0]};
  for (int n = 1; n < argc; ++n) {
    if (std::strncmp(argv[n], "--molecule=", 11) == 0) {
      tracemesh::molecule_file = argv[n] + 11;
    } else if (std::strncmp(argv[n], "--density=", 10) == 0) {
      tracemesh::density = std::atof(argv[n] + 10);
    } else {
      rest.push_back(argv[n]);
    }
  }
  int rest_count = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_count, rest.data());
  using namespace tracemesh;
  benchmark::RegisterBenchmark("field_construction", field_construction)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("culling", culling)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("block_atoms", block_atoms)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("sampling", sampling)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("triangulation", triangulation)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edge_roots", edge_roots)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("trace_line_roots", trace_line_roots)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("point_value", point_value)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("point_value_and_gradient", point_value_and_gradient)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("point_probe", point_probe)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("point_dominant_atom", point_dominant_atom)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("point_projection", point_projection)->Unit(benchmark::kMillisecond);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
