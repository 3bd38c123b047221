#pragma once
/// @file nanoshaper_command.hpp
/// `tracemesh nanoshaper [CONF.prm]`, also run when the program is invoked as `NanoShaper` (a link of that name):
/// the NanoShaper command line that boundary-element solvers run, answered with a certified Gaussian surface
/// (docs/nanoshaper.md).

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/progress.hpp"
#include "core/status.hpp"

namespace tracemesh::cli::nanoshaper {

/// NanoShaper's configuration file when none is named: surfaceConfiguration.prm in the working directory.
inline constexpr const char* default_configuration = "surfaceConfiguration.prm";

/// Whether `argv0` names NanoShaper: its last path component is exactly "NanoShaper".
bool invoked_as_nanoshaper(std::string_view argv0);

/// The outcome of reading the subcommand's arguments.
struct nanoshaper_command_line {
  std::optional<std::filesystem::path> configuration;  ///< set when the program should run
  int exit_code = 0;             ///< otherwise exit with this code (0 after --help, 2 for misuse)
  std::string standard_output;   ///< after printing this (the usage) to stdout
  std::string error;             ///< or this one-line message to stderr
};

/// `arguments`: those after "nanoshaper" (or after argv[0] when invoked as NanoShaper). None: the default
/// configuration; one: the configuration's path; -h or --help: the usage. Anything more is misuse.
nanoshaper_command_line parse_nanoshaper_command_line(const std::vector<std::string_view>& arguments);

/// Reads `configuration` (prm_file.hpp, nanoshaper_job.hpp), meshes the Gaussian surface of its XYZR_FileName and
/// writes the mesh files NanoShaper would, atomically, in Output_Folder or the working directory; their earlier
/// versions are removed first, so that a client that ignores the exit status never reads an old mesh. Warnings
/// and the surface substitution go to `diagnostics` ("tracemesh: warning: ..."), one line each; a one-line summary
/// of the files written to `summary`.
/// Errors: errc::invalid_input naming the file and line (a malformed configuration or value), the errors of
/// read_molecule_file (the xyzr file) and mesh_molecule (cancelled through `progress`, or no certified mesh), and
/// errc::io_error when a file cannot be read or written. Nothing is written unless a certified mesh was made.
status run_nanoshaper(const std::filesystem::path& configuration, progress_token& progress, std::FILE* diagnostics,
                      std::FILE* summary);

}  // namespace tracemesh::cli::nanoshaper
