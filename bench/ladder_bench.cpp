// Meshes one molecule at one density several times and prints one Markdown table row:
// atoms, density, seconds per stage and total (medians), peak RSS of the first run (one job, as the service runs
// it), vertices, triangles, achieved density, edge-ratio mean, certificate. bench/run_ladder.sh runs it once per
// molecule and density (one process each, so peak RSS belongs to that row alone).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "core/mesher.hpp"
#include "core/io/pqr_reader.hpp"

namespace {

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: ladder_bench FILE.pqr[.gz] DENSITY [RUNS=3] [--header]\n");
    return 2;
  }
  if (argc > 4 && std::string(argv[4]) == "--header") {
    std::printf("| molecule | atoms | density | read s | culling s | sampling+roots s | triangulating s | refining s | "
                "certifying s | total s | peak RSS MB | vertices | triangles | vertices/Å² | edge ratio mean | "
                "< 0.2 | certified |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  }
  const std::string path = argv[1];
  const double density = std::atof(argv[2]);
  const int runs = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;

  const auto read_start = std::chrono::steady_clock::now();
  auto mol = tracemesh::read_pqr_file(path);
  const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
  if (!mol) {
    std::fprintf(stderr, "ladder_bench: %s\n", mol.error().message().c_str());
    return 1;
  }
  tracemesh::mesh_params params;
  params.density = density;
  std::map<tracemesh::mesh_stage, std::vector<double>> stage_seconds;
  std::vector<double> totals;
  tracemesh::mesh_output last;
  double first_run_peak_mb = 0;  // one job's peak: later runs start with the previous mesh still held
  for (int run = 0; run < runs; ++run) {
    tracemesh::progress_token progress;
    const auto start = std::chrono::steady_clock::now();
    auto out = tracemesh::mesh_molecule(*mol, params, {}, progress);
    totals.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    if (!out) {
      std::fprintf(stderr, "ladder_bench: %s\n", out.error().message().c_str());
      return 1;
    }
    for (const auto& timing : out->timings) stage_seconds[timing.stage].push_back(timing.seconds);
    if (run == 0) first_run_peak_mb = peak_rss_mb();
    last = std::move(*out);
  }
  const auto stage = [&](tracemesh::mesh_stage s) {
    return stage_seconds.count(s) ? median(stage_seconds[s]) : 0.0;
  };
  const std::string name = path.substr(path.find_last_of('/') + 1);
  const auto& r = last.report;
  std::printf("| %s | %zu | %g | %.2f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.0f | %zu | %zu | %.2f | %.3f | %.2f%% | %s |\n",
              name.c_str(), mol->atoms.size(), density, read_seconds, stage(tracemesh::mesh_stage::culling),
              stage(tracemesh::mesh_stage::sampling) + stage(tracemesh::mesh_stage::roots),
              stage(tracemesh::mesh_stage::triangulating),
              stage(tracemesh::mesh_stage::refining), stage(tracemesh::mesh_stage::certifying), median(totals),
              first_run_peak_mb, r.vertices, r.triangles, r.achieved_density, r.quality.edge_ratio_mean,
              100 * r.quality.fraction_below_0_2, last.certified ? "yes" : "NO");
  return last.certified ? 0 : 1;
}
