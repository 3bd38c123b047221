// Meshes one molecule at one density with one path (lattice or trace, raw or refined) several times and prints one
// Markdown table row: seconds per stage and total (medians), CPU seconds (median), peak RSS of the first run (one
// job, as the service runs it), vertices, triangles, achieved density, field evaluations per vertex and fallback
// loops (trace), edge-ratio mean and share below 0.2, certificate. With --json FILE it also appends the same row as
// one JSON object per line (with the full report of the last run and a 100-bin edge-ratio histogram, for plots).
// A molecule or run that fails still prints its row, saying "failed" and why (exit status 1).
// bench/run_ladder.sh and bench/run_paper.sh run it once per row, one process each, so peak RSS is that row's alone.
#include <sys/resource.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/io/pqr_reader.hpp"
#include "core/mesher.hpp"
#include "proto/report_json.hpp"

namespace {

using tracemesh::mesh_stage;

constexpr const char* usage_text =
    "usage: ladder_bench FILE.pqr[.gz] DENSITY [RUNS=3] [--runs N] [--method trace|lattice] [--refine none|full]\n"
    "                    [--threads N] [--json FILE|-] [--header]\n"
    "  --threads 0 (default) uses every core; --json appends one JSON object per row to FILE ('-': stdout);\n"
    "  --header prints the Markdown table header first (alone: `ladder_bench --header`).\n"
    "  Exit status: 0 row measured, 1 row failed (the row says why), 2 usage.\n";

/// The stage columns of the table, in pipeline order; a stage the path does not run prints "—".
constexpr std::array<mesh_stage, 7> stage_columns = {
    mesh_stage::culling,       mesh_stage::sampling, mesh_stage::roots,     mesh_stage::tracing,
    mesh_stage::triangulating, mesh_stage::refining, mesh_stage::certifying};
constexpr int table_columns = 24;  // 6 before the stages, the 7 stages, 11 after
constexpr std::size_t edge_ratio_bins = 100;

struct options {
  std::string path;
  double density = 0;
  int runs = 3;
  tracemesh::mesh_method method = tracemesh::mesh_method::lattice;
  tracemesh::refine_mode refine = tracemesh::refine_mode::full;
  unsigned threads = 0;
  std::string json_path;  // empty: no JSON row
  bool header = false;
};

/// What one row reports: medians over the runs, or why it failed.
struct row {
  std::string molecule, error;
  std::size_t atoms = 0;
  unsigned threads = 0;
  double read_seconds = 0, total_seconds = 0, cpu_seconds = 0, peak_rss_mb = 0;
  std::map<mesh_stage, double> stage_seconds;  // only the stages the path ran
  tracemesh::mesh_output out;                  // the last run's
  std::array<std::size_t, edge_ratio_bins> edge_ratio_histogram{};
};

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

std::string path_label(const options& opt) {
  return std::string(tracemesh::method_name(opt.method)) +
         (opt.refine == tracemesh::refine_mode::full ? " refined" : " raw");
}

bool usage_error(const std::string& why) {
  std::fprintf(stderr, "ladder_bench: %s\n%s", why.c_str(), usage_text);
  return false;
}

/// Parses the command line; false (after printing why) on a usage error.
bool parse_options(int argc, char** argv, options& opt) {
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const char* value = i + 1 < argc ? argv[i + 1] : nullptr;
    if (arg == "--header") {
      opt.header = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) {
      positional.push_back(arg);
      continue;
    }
    if (!value) return usage_error(arg + " needs a value");
    ++i;
    if (arg == "--runs") opt.runs = std::atoi(value);
    else if (arg == "--threads") opt.threads = static_cast<unsigned>(std::max(0, std::atoi(value)));
    else if (arg == "--json") opt.json_path = value;
    else if (arg == "--method") {
      if (!tracemesh::parse_method(value, opt.method)) return usage_error("bad --method " + std::string(value));
    } else if (arg == "--refine") {
      if (!tracemesh::parse_refine(value, opt.refine)) return usage_error("bad --refine " + std::string(value));
    } else {
      return usage_error("unknown option " + arg);
    }
  }
  if (positional.size() < 2 || positional.size() > 3) return usage_error("expected FILE DENSITY [RUNS]");
  opt.path = positional[0];
  opt.density = std::atof(positional[1].c_str());
  if (positional.size() == 3) opt.runs = std::atoi(positional[2].c_str());
  opt.runs = std::max(1, opt.runs);
  return true;
}

tracemesh::mesh_params mesh_params_of(const options& opt) {
  tracemesh::mesh_params params;
  params.density = opt.density;
  params.method = opt.method;
  params.refine = opt.refine;
  params.threads = opt.threads;
  return params;
}

/// Histogram of shortest/longest edge over the mesh's triangles, bins [0, 0.01), …, [0.99, 1].
std::array<std::size_t, edge_ratio_bins> edge_ratio_histogram(const tracemesh::surface_mesh& mesh) {
  std::array<std::size_t, edge_ratio_bins> bins{};
  for (const auto& t : mesh.triangles) {
    const auto& p = mesh.positions;
    const std::array<double, 3> edges = {tracemesh::distance(p[t[0]], p[t[1]]), tracemesh::distance(p[t[1]], p[t[2]]),
                                         tracemesh::distance(p[t[2]], p[t[0]])};
    const double longest = *std::max_element(edges.begin(), edges.end());
    const double ratio = longest > 0 ? *std::min_element(edges.begin(), edges.end()) / longest : 0.0;
    ++bins[std::min(edge_ratio_bins - 1, static_cast<std::size_t>(ratio * static_cast<double>(edge_ratio_bins)))];
  }
  return bins;
}

/// Reads the molecule and meshes it opt.runs times; fills `r` (r.error non-empty when a step failed).
void measure(const options& opt, row& r) {
  const auto read_start = std::chrono::steady_clock::now();
  auto mol = tracemesh::read_pqr_file(opt.path);
  r.read_seconds = seconds_since(read_start);
  if (!mol) {
    r.error = "reading: " + mol.error().message();
    return;
  }
  r.atoms = mol->atoms.size();

  const tracemesh::mesh_params params = mesh_params_of(opt);
  std::map<mesh_stage, std::vector<double>> stage_runs;
  std::vector<double> totals, cpu;
  for (int run = 0; run < opt.runs; ++run) {
    tracemesh::progress_token progress;
    const double cpu_start = cpu_seconds();
    const auto start = std::chrono::steady_clock::now();
    auto out = tracemesh::mesh_molecule(*mol, params, {}, progress);
    totals.push_back(seconds_since(start));
    cpu.push_back(cpu_seconds() - cpu_start);
    if (run == 0) r.peak_rss_mb = peak_rss_mb();  // later runs start with the previous mesh still held
    if (!out) {
      r.error = out.error().message();
      if (opt.runs > 1) r.error += " (run " + std::to_string(run + 1) + " of " + std::to_string(opt.runs) + ")";
      return;
    }
    if (!out->fallback_reason.empty()) {  // a lattice mesh: not a measurement of the trace path
      r.error = "the trace path failed and the lattice path meshed instead: " + out->fallback_reason;
      return;
    }
    std::map<mesh_stage, double> this_run;
    for (const auto& timing : out->timings) this_run[timing.stage] += timing.seconds;
    for (const auto& [stage, seconds] : this_run) stage_runs[stage].push_back(seconds);
    r.out = std::move(*out);
  }
  for (const auto& [stage, seconds] : stage_runs) r.stage_seconds[stage] = median(seconds);
  r.total_seconds = median(totals);
  r.cpu_seconds = median(cpu);
  r.edge_ratio_histogram = edge_ratio_histogram(r.out.mesh);
}

/// A table cell without the characters that would break the row.
std::string cell(std::string text) {
  std::replace(text.begin(), text.end(), '|', '/');
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

void print_header() {
  std::printf("| molecule | atoms | density | path | threads | read s |");
  for (const mesh_stage stage : stage_columns) std::printf(" %s s |", tracemesh::stage_name(stage));
  std::printf(" total s | CPU s | peak RSS MB | vertices | triangles | vertices/Å² | evals/vertex | fallback loops |"
              " edge ratio mean | < 0.2 | certified |\n|");
  for (int c = 0; c < table_columns; ++c) std::printf("---|");
  std::printf("\n");
}

void print_row(const options& opt, const row& r) {
  const std::string atoms = r.atoms ? std::to_string(r.atoms) : "";
  std::printf("| %s | %s | %g | %s | %u |", r.molecule.c_str(), atoms.c_str(), opt.density, path_label(opt).c_str(),
              r.threads);
  if (!r.error.empty()) {
    std::printf(" failed: %s |", cell(r.error).c_str());
    for (int c = 6; c < table_columns; ++c) std::printf(" |");
    std::printf("\n");
    return;
  }
  std::printf(" %.2f |", r.read_seconds);
  for (const mesh_stage stage : stage_columns) {
    const auto found = r.stage_seconds.find(stage);
    if (found == r.stage_seconds.end()) std::printf(" — |");
    else std::printf(" %.3f |", found->second);
  }
  const auto& rep = r.out.report;
  const auto& trace = r.out.trace;
  const bool traced = opt.method == tracemesh::mesh_method::trace;
  const double evals_per_vertex = trace.raw_vertices ? static_cast<double>(trace.field_evaluations) /
                                                           static_cast<double>(trace.raw_vertices)
                                                     : 0.0;
  std::printf(" %.3f | %.3f | %.0f | %zu | %zu | %.2f |", r.total_seconds, r.cpu_seconds, r.peak_rss_mb, rep.vertices,
              rep.triangles, rep.achieved_density);
  if (traced) std::printf(" %.1f | %zu |", evals_per_vertex, trace.fallback_loops);
  else std::printf(" — | — |");
  std::printf(" %.3f | %.2f%% | %s |\n", rep.quality.edge_ratio_mean, 100 * rep.quality.fraction_below_0_2,
              r.out.certified ? "yes" : "NO");
}

nlohmann::json row_json(const options& opt, const row& r) {
  nlohmann::json json = {
      {"molecule", r.molecule},
      {"file", opt.path},
      {"atoms", r.atoms},
      {"density", opt.density},
      {"method", tracemesh::method_name(opt.method)},
      {"refine", tracemesh::refine_name(opt.refine)},
      {"path", path_label(opt)},
      {"threads", r.threads},
      {"runs", opt.runs},
      {"status", r.error.empty() ? "ok" : "failed"},
      {"error", r.error},
      {"read_seconds", r.read_seconds},
      {"peak_rss_mb", r.peak_rss_mb},
  };
  if (!r.error.empty()) return json;
  nlohmann::json seconds = nlohmann::json::object();
  for (const auto& [stage, value] : r.stage_seconds) seconds[tracemesh::stage_name(stage)] = value;
  seconds["total"] = r.total_seconds;
  json["seconds"] = std::move(seconds);  // medians over the runs; "total" is the wall time of mesh_molecule
  json["cpu_seconds"] = r.cpu_seconds;
  json["edge_ratio_bins"] = r.edge_ratio_histogram;  // [0, 0.01), …, [0.99, 1]
  json["report"] = tracemesh::proto::report_to_json(r.out, mesh_params_of(opt));  // the last run's
  return json;
}

bool append_json(const std::string& path, const nlohmann::json& json) {
  const std::string line = json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  if (path == "-") return std::fputs(line.c_str(), stdout) >= 0;
  std::FILE* file = std::fopen(path.c_str(), "a");
  if (!file) return false;
  const bool written = std::fputs(line.c_str(), file) >= 0;
  return std::fclose(file) == 0 && written;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--header") {  // the header alone, for scripts
    print_header();
    return 0;
  }
  options opt;
  if (!parse_options(argc, argv, opt)) return 2;
  if (opt.header) print_header();
  row r;
  r.molecule = opt.path.substr(opt.path.find_last_of('/') + 1);
  r.threads = opt.threads ? opt.threads : static_cast<unsigned>(tbb::this_task_arena::max_concurrency());
  try {
    measure(opt, r);
  } catch (const std::exception& e) {  // std::bad_alloc on a row too big for the machine: still a row
    r.error = std::string("exception: ") + e.what();
  }
  print_row(opt, r);
  std::fflush(stdout);
  if (!opt.json_path.empty() && !append_json(opt.json_path, row_json(opt, r))) {
    std::fprintf(stderr, "ladder_bench: cannot append to %s\n", opt.json_path.c_str());
    return 1;
  }
  return r.error.empty() ? 0 : 1;
}
