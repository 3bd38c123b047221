#include "cli/run.hpp"

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "cli/atomic_file.hpp"
#include "core/mesher.hpp"
#include "core/io/structure/molecule_reader.hpp"
#include "proto/mesh_encoders.hpp"
#include "proto/report_json.hpp"

namespace tracemesh::cli {
namespace {

using clock_type = std::chrono::steady_clock;

double seconds_since(clock_type::time_point start) {
  return std::chrono::duration<double>(clock_type::now() - start).count();
}

/// The encoded mesh: one buffer per output path (two for MSMS). `input` keeps what the report states about the
/// delivered bytes (the Draco quantisation and the decoded mesh's check).
result<std::vector<std::string>> encode(const proto::encoder_input& input, output_format format) {
  if (format.msms) {
    return std::vector<std::string>{proto::encode_msms_vert(input.mesh()), proto::encode_msms_face(input.mesh())};
  }
  result<std::string> bytes = proto::format_info(format.mesh).encode(input);
  if (!bytes) return bytes.error();
  return std::vector<std::string>{std::move(bytes).value()};
}

status write_outputs(const cli_options& options, const std::vector<std::string>& encoded) {
  const std::vector<std::filesystem::path> paths = output_paths(options.output, options.format);
  std::vector<file_contents> files;
  for (std::size_t i = 0; i < paths.size() && i < encoded.size(); ++i) files.push_back({paths[i], encoded[i]});
  return write_files_atomically(files);
}

status write_report(const std::string& destination, const nlohmann::json& report) {
  const std::string text = report.dump(2) + "\n";
  if (destination != "-") return write_file_atomically(destination, text);
  if (std::fwrite(text.data(), 1, text.size(), stdout) != text.size() || std::fflush(stdout) != 0) {
    return {errc::io_error, "cannot write the report to stdout"};
  }
  return status::success();
}

void print_summary(const mesh_output& output) {
  for (const stage_timing& timing : output.timings) {
    std::fprintf(stderr, "tracemesh: %-13s %9.3f s\n", stage_name(timing.stage), timing.seconds);
  }
  if (output.failed_attempt_seconds > 0) {
    std::fprintf(stderr, "tracemesh: %-13s %9.3f s\n", "failed tries", output.failed_attempt_seconds);
  }
  const mesh_method used = method_used(output.method, output);
  if (used == mesh_method::trace) {
    const trace_stats& t = output.trace;
    std::fprintf(stderr,
                 "tracemesh: trace: %zu lines, %zu polygons, %zu fallback loops, %zu welded edges, %zu collapsed raw "
                 "edges, %zu level-shifted strips, %zu untouched cavities (%zu left out), %zu line grid retries, %zu raw "
                 "vertices, %.1f field evaluations per vertex\n",
                 t.lines, t.polygons, t.fallback_loops, t.welded_edges, t.collapsed_raw_edges, t.level_shifted_strips,
                 t.untouched_cavities, t.untouched_cavities_left, t.grid_retries, t.raw_vertices,
                 t.raw_vertices == 0 ? 0.0
                                     : static_cast<double>(t.field_evaluations) / static_cast<double>(t.raw_vertices));
  }
  std::fprintf(stderr, "tracemesh: %zu atoms, %zu vertices, %zu triangles, area %.2f Å², volume %.2f Å³, %s %s, %s\n",
               output.atoms_meshed, output.report.vertices, output.report.triangles, output.report.area,
               output.report.volume, method_name(used), refine_name(output.refine),
               output.certified ? "certified" : "NOT certified");
}

}  // namespace

status run(const cli_options& options, progress_token& progress) {
  const mesh_limits limits;
  auto start = clock_type::now();
  progress.report(mesh_stage::reading, 0);
  const structure_options input_options =
      declared_by_file_name(options.input.filename().string(), options.input_options);
  result<read_molecule_result> read = read_molecule_file(options.input, input_options, limits);
  if (!read) return read.error();
  const molecule* mol = &read->mol;
  const double reading_seconds = seconds_since(start);
  if (!progress.report(mesh_stage::reading, 1)) return {errc::cancelled, "cancelled"};

  result<mesh_output> meshed = mesh_molecule(*mol, options.params, limits, progress);
  if (!meshed) return meshed.error();
  mesh_output& output = *meshed;
  if (!output.fallback_reason.empty()) {
    std::fprintf(stderr, "tracemesh: warning: the trace path failed (%s); the lattice path made this mesh\n",
                 output.fallback_reason.c_str());
  }
  output.timings.insert(output.timings.begin(), {mesh_stage::reading, reading_seconds});

  start = clock_type::now();
  progress.report(mesh_stage::encoding, 0);
  const proto::encoder_input input(output.mesh);
  const result<std::vector<std::string>> encoded = encode(input, options.format);
  if (!encoded) return encoded.error();
  output.timings.push_back({mesh_stage::encoding, seconds_since(start)});
  if (!progress.report(mesh_stage::done, 1)) return {errc::cancelled, "cancelled"};

  if (status written = write_outputs(options, *encoded); !written) return written;
  if (options.report) {
    nlohmann::json report =
        proto::report_to_json(output, options.params, proto::summarize_input(*read));
    if (!options.format.msms) {
      const proto::mesh_format format = options.format.mesh;
      report["encodings"] = {{std::string(proto::format_name(format)),
                              proto::encoding_to_json(input, format, encoded->front().size())}};
    }
    if (status written = write_report(*options.report, report); !written) return written;
  }
  if (options.verbose) print_summary(output);
  return status::success();
}

}  // namespace tracemesh::cli
