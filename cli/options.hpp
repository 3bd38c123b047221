#pragma once
/// @file options.hpp
/// The `tracemesh` command line:
///   tracemesh INPUT[.gz] -o OUT.{off,drc,glb,ply,vert} [--radii bondi|mantina] [--hydrogens keep|drop]
///             [--waters keep|drop] [--ligands keep|drop] [--assembly ID|asu] [--density 1] [--d -1] [--t0 1]
///             [--method trace|lattice] [--refine none|full] [--cavities keep|drop] [--trace-degree N] [--trace-step F] [--trace-cos-bound F]
///             [--trace-extreme-tolerance F] [--threads N] [--format off|draco|glb|glb-raw|ply|msms] [--report FILE|-] [--verbose]
/// Parameters are parsed exactly as the HTTP service parses them (proto::parse_mesh_params; option --x-y is the
/// service's field x_y), with the same defaults (mesh_params{}); an error names the option ("trace-step must be
/// ..."), and is a usage error (exit 2).

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/input_format.hpp"
#include "core/mesher.hpp"
#include "core/status.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::cli {

/// Worker threads accepted by --threads (0 = all cores); more is a typo, not a machine.
inline constexpr unsigned max_threads = 1024;

/// What the command writes: one of the service's formats (proto's format table), or the MSMS .vert/.face pair.
struct output_format {
  proto::mesh_format mesh = proto::mesh_format::off;  ///< the format written, unless `msms`
  bool msms = false;                                  ///< the MSMS .vert/.face pair instead
  bool operator==(const output_format&) const = default;
};

/// A name of the format table, or "msms"; errc::invalid_argument otherwise.
result<output_format> parse_output_format(std::string_view name);

/// From the output's extension (case-insensitive): the format table's (.off, .drc, .glb → glb, .ply), or
/// .vert/.face → msms. errc::invalid_argument for any other extension (then --format is needed).
result<output_format> infer_output_format(const std::filesystem::path& output);

/// The files written for `output`: itself, or for msms its .vert and .face siblings (extension replaced).
std::vector<std::filesystem::path> output_paths(const std::filesystem::path& output, output_format format);

struct cli_options {
  std::filesystem::path input;
  std::filesystem::path output;
  output_format format;
  mesh_params params;
  structure_options input_options;    ///< how PDB/mmCIF inputs are read (core/io/input_format.hpp)
  std::optional<std::string> report;  ///< report destination: a path, or "-" for stdout
  bool verbose = false;               ///< timings and a summary on stderr
};

/// The outcome of parsing the command line.
struct parsed_command_line {
  std::optional<cli_options> options;  ///< set when the program should run
  int exit_code = 0;                   ///< otherwise exit with this code (0 for --help/--version, 2 for misuse)
  std::string standard_output;         ///< after printing this (help, version) to stdout
  std::string error;                   ///< or this one-line message to stderr
};

/// Parses argv. Never throws and never prints.
parsed_command_line parse_command_line(int argc, const char* const* argv);

}  // namespace tracemesh::cli
