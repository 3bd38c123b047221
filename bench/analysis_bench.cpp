// Google Benchmark: mesh analysis and the self-intersection test on large icospheres (5.2 M and 21 M triangles are
// levels 9 and 10; the issue asks for a few seconds at 10⁷ triangles).
//   build/bin/analysis_bench --benchmark_min_time=0.1
#include <benchmark/benchmark.h>

#include "core/analysis/mesh_analysis.hpp"
#include "support/analysis_meshes.hpp"

namespace {

void count_self_intersections_icosphere(benchmark::State& state) {
  const tracemesh::surface_mesh mesh = tracemesh::testing::icosphere(static_cast<int>(state.range(0)), 50.0);
  for (auto _ : state) benchmark::DoNotOptimize(tracemesh::count_self_intersections(mesh));
  state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
}

void analyze_mesh_icosphere(benchmark::State& state) {
  const tracemesh::surface_mesh mesh = tracemesh::testing::icosphere(static_cast<int>(state.range(0)), 50.0);
  for (auto _ : state) benchmark::DoNotOptimize(tracemesh::analyze_mesh(mesh));
  state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
}

}  // namespace

BENCHMARK(count_self_intersections_icosphere)->Arg(7)->Arg(8)->Arg(9)->Unit(benchmark::kMillisecond);
BENCHMARK(analyze_mesh_icosphere)->Arg(7)->Arg(8)->Arg(9)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
