#include "cli/nanoshaper/nanoshaper_command.hpp"

#include <fstream>
#include <iterator>
#include <system_error>

#include "cli/atomic_file.hpp"
#include "cli/nanoshaper/nanoshaper_files.hpp"
#include "cli/nanoshaper/nanoshaper_job.hpp"
#include "cli/nanoshaper/prm_file.hpp"
#include "core/io/structure/molecule_reader.hpp"
#include "core/mesher.hpp"
#include "proto/mesh_encoders.hpp"

namespace tracemesh::cli::nanoshaper {
namespace {

namespace fs = std::filesystem;

constexpr const char* usage =
    "Usage: tracemesh nanoshaper [CONF.prm]\n"
    "       NanoShaper [CONF.prm]   (tracemesh through a link named NanoShaper)\n"
    "\n"
    "Reads a NanoShaper configuration (default: surfaceConfiguration.prm in the working directory), meshes the\n"
    "Gaussian surface of its XYZR_FileName and writes the files NanoShaper would write there:\n"
    "triangulatedSurf.vert/.face (Save_Mesh_MSMS_Format), .ply (Save_Mesh_PLY_Format) or .off, after\n"
    "Root_FileName, in Output_Folder. Exit status 0 only when a certified mesh was written.\n"
    "Keys, the surfaces meshed for ses and skin and the Grid_scale rule: docs/nanoshaper.md.\n";

/// The configuration's text: errc::io_error naming the path, or errc::invalid_input when it is too large to be one.
result<std::string> read_configuration(const fs::path& path) {
  std::error_code error;
  const std::uintmax_t size = fs::file_size(path, error);
  if (error) return status(errc::io_error, "cannot read " + path.string() + ": " + error.message());
  if (size > max_prm_bytes) {
    return status(errc::invalid_input, path.string() + ": " + std::to_string(size) +
                                           " bytes: not a NanoShaper configuration");
  }
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in && !in.eof()) return status(errc::io_error, "cannot read " + path.string());
  return text;
}

/// The job of the configuration file.
result<nanoshaper_job> read_configured_job(const fs::path& configuration) {
  const result<std::string> text = read_configuration(configuration);
  if (!text) return text.error();
  const result<prm_file> file = parse_prm(*text);
  if (!file) return status(file.error().code(), configuration.string() + ": " + file.error().message());
  result<nanoshaper_job> job = read_job(*file);
  if (!job) return status(job.error().code(), configuration.string() + ": " + job.error().message());
  return job;
}

/// The job's warnings and substitution, one line each.
void print_diagnostics(const nanoshaper_job& job, const fs::path& configuration, std::FILE* diagnostics) {
  for (const std::string& warning : job.warnings) {
    std::fprintf(diagnostics, "tracemesh: warning: %s: %s\n", configuration.string().c_str(), warning.c_str());
  }
  if (!job.substitution.empty()) std::fprintf(diagnostics, "tracemesh: %s\n", job.substitution.c_str());
}

/// The files' bytes, in the order of mesh_files(job).
result<std::vector<std::string>> encode(const nanoshaper_job& job, const surface_mesh& mesh) {
  switch (job.format) {
    case mesh_file_format::msms: return std::vector<std::string>{nanoshaper_vert(mesh), nanoshaper_face(mesh)};
    case mesh_file_format::ply: {
      result<std::string> bytes = proto::encode_ply(proto::encoder_input(mesh));
      if (!bytes) return bytes.error();
      return std::vector<std::string>{std::move(bytes).value()};
    }
    case mesh_file_format::off: break;
  }
  if (job.off_normals || job.off_atoms) {
    return std::vector<std::string>{nanoshaper_off(mesh, job.off_normals, job.off_atoms)};
  }
  result<std::string> bytes = proto::encode_off(proto::encoder_input(mesh));
  if (!bytes) return bytes.error();
  return std::vector<std::string>{std::move(bytes).value()};
}

/// The output folder (created, as NanoShaper does), and the job's earlier mesh files removed from it.
status prepare_output_folder(const nanoshaper_job& job, const std::vector<fs::path>& outputs) {
  std::error_code error;
  if (!job.output_folder.empty()) {
    fs::create_directories(job.output_folder, error);
    if (error) return {errc::io_error, "cannot create Output_Folder " + job.output_folder.string() + ": " +
                                           error.message()};
  }
  for (const fs::path& output : outputs) {
    fs::remove(output, error);
    if (error) return {errc::io_error, "cannot remove the earlier " + output.string() + ": " + error.message()};
  }
  return status::success();
}

/// Where the paths of the configuration lead: NanoShaper changes into Output_Folder before reading anything.
fs::path in_output_folder(const nanoshaper_job& job, const fs::path& path) {
  return job.output_folder.empty() || path.is_absolute() ? path : job.output_folder / path;
}

/// Reads and meshes the job's xyzr file. The job's diagnostics are printed once the file is read: a configuration
/// or xyzr file that cannot be used fails with its one error line alone.
result<mesh_output> mesh_xyzr_file(const nanoshaper_job& job, const fs::path& configuration, progress_token& progress,
                                   std::FILE* diagnostics) {
  const mesh_limits limits;
  structure_options input;
  input.format = declared_format{input_format::xyzr, "XYZR_FileName"};
  const fs::path xyzr = in_output_folder(job, job.xyzr);
  const result<read_molecule_result> read = read_molecule_file(xyzr, input, limits);
  if (!read) return status(read.error().code(), "XYZR_FileName " + xyzr.string() + ": " + read.error().message());
  print_diagnostics(job, configuration, diagnostics);
  result<mesh_output> meshed = mesh_molecule(read->mol, job.params, limits, progress);
  if (meshed && !meshed->fallback_reason.empty()) {
    std::fprintf(diagnostics, "tracemesh: warning: the trace path failed (%s); the lattice path made this mesh\n",
                 meshed->fallback_reason.c_str());
  }
  return meshed;
}

}  // namespace

bool invoked_as_nanoshaper(std::string_view argv0) {
  const std::size_t slash = argv0.find_last_of('/');
  return argv0.substr(slash == std::string_view::npos ? 0 : slash + 1) == "NanoShaper";
}

nanoshaper_command_line parse_nanoshaper_command_line(const std::vector<std::string_view>& arguments) {
  nanoshaper_command_line parsed;
  if (arguments.size() == 1 && (arguments[0] == "-h" || arguments[0] == "--help")) {
    parsed.standard_output = usage;
    return parsed;
  }
  if (arguments.size() > 1 || (arguments.size() == 1 && arguments[0].starts_with('-'))) {
    parsed.exit_code = 2;
    parsed.error = "nanoshaper takes one argument, the configuration file (see tracemesh nanoshaper --help)";
    return parsed;
  }
  parsed.configuration = arguments.empty() ? fs::path(default_configuration) : fs::path(arguments[0]);
  return parsed;
}

status run_nanoshaper(const fs::path& configuration, progress_token& progress, std::FILE* diagnostics,
                      std::FILE* summary) {
  const result<nanoshaper_job> job = read_configured_job(configuration);
  if (!job) return job.error();
  std::vector<fs::path> outputs;
  for (const fs::path& name : mesh_files(*job)) outputs.push_back(in_output_folder(*job, name));
  if (status prepared = prepare_output_folder(*job, outputs); !prepared) return prepared;

  const result<mesh_output> meshed = mesh_xyzr_file(*job, configuration, progress, diagnostics);
  if (!meshed) return meshed.error();
  const result<std::vector<std::string>> encoded = encode(*job, meshed->mesh);
  if (!encoded) return encoded.error();
  std::vector<file_contents> files;
  for (std::size_t i = 0; i < outputs.size(); ++i) files.push_back({outputs[i], (*encoded)[i]});
  if (status written = write_files_atomically(files); !written) return written;

  std::string names;
  for (const fs::path& output : outputs) names += (names.empty() ? "" : ", ") + output.string();
  std::fprintf(summary, "tracemesh: wrote %s: %zu vertices, %zu triangles, area %.2f Å², volume %.2f Å³, certified\n",
               names.c_str(), meshed->report.vertices, meshed->report.triangles, meshed->report.area,
               meshed->report.volume);
  return status::success();
}

}  // namespace tracemesh::cli::nanoshaper
