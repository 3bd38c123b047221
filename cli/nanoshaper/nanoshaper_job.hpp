#pragma once
/// @file nanoshaper_job.hpp
/// What a NanoShaper configuration asks for, in tracemesh's terms: the molecule, the Gaussian surface and density
/// that stand in for NanoShaper's surface and grid, and the files NanoShaper would write. docs/nanoshaper.md is the
/// user's account of every rule here and of the measurements behind the constants.

#include <filesystem>
#include <string>
#include <vector>

#include "cli/nanoshaper/prm_file.hpp"
#include "core/mesher.hpp"
#include "core/status.hpp"

namespace tracemesh::cli::nanoshaper {

/// NanoShaper's `Surface` values that tracemesh meshes (the others, such as mesh or coulombic, are refused).
enum class surface_kind { ses, skin, blobby };

/// The file family NanoShaper writes: MSMS .vert/.face (Save_Mesh_MSMS_Format), PLY (Save_Mesh_PLY_Format, which
/// wins over MSMS as in NanoShaper), or its OFF variants (neither key).
enum class mesh_file_format { msms, ply, off };

/// A Gaussian surface {φ = t0} with kernel decay d (mesh_params::d, t0).
struct gaussian_surface {
  double d;
  double t0;
};

/// NanoShaper's defaults for the keys tracemesh honours, used when a file leaves one out (NanoShaper's own).
inline constexpr double default_grid_scale = 2.0;  ///< grid points per Å
inline constexpr double default_blobbyness = -2.5;
inline constexpr const char* default_xyzr_file = "temp.xyzr";
/// The stem of every mesh file NanoShaper writes ("triangulatedSurf.vert", ...), after Root_FileName.
inline constexpr const char* mesh_file_stem = "triangulatedSurf";

/// The Gaussian surfaces meshed for Surface = ses and skin: the (d, t0) whose area and volume come closest to
/// NanoShaper's SES (probe 1.4 Å) and skin (s = 0.45) on the test molecules (bench/nanoshaper_equivalence.py fit;
/// the table is in docs/nanoshaper.md). Neither is the SES: a Gaussian surface has no probe and no concave arcs.
inline constexpr gaussian_surface ses_substitute{-1.1, 2.0};
inline constexpr gaussian_surface skin_substitute{-1.25, 2.0};
/// The probe radius and skin parameter the substitutes were measured at (TABI-PB's values); other values are
/// warned about, since they do not change the Gaussian surface.
inline constexpr double substitute_probe_radius = 1.4;
inline constexpr double substitute_skin_parameter = 0.45;

/// Grid_scale g (grid points per Å) → tracemesh density (vertices per Å²): density = k·g², clamped to
/// parameter_ranges. NanoShaper's marching cubes puts about k vertices per Å² per (point per Å)² on the surface
/// (measured: the vertices table of docs/nanoshaper.md), so the vertex counts come out close.
inline constexpr double density_per_grid_scale_squared = 1.5;

/// The job a configuration describes.
struct nanoshaper_job {
  std::filesystem::path xyzr;           ///< XYZR_FileName as written (relative paths are from output_folder)
  surface_kind surface = surface_kind::ses;
  double grid_scale = default_grid_scale;
  mesh_params params;                   ///< d, t0, density and threads; the rest tracemesh's defaults
  mesh_file_format format = mesh_file_format::off;
  bool off_normals = false;             ///< OFF+N: Compute_Vertex_Normals
  bool off_atoms = false;               ///< OFF+A: Vertex_Atom_Info
  std::string root;                     ///< Root_FileName, prefixed to every file name
  std::filesystem::path output_folder;  ///< Output_Folder (created if absent); empty: the working directory
  /// One line each (no prefix): unknown keys, keys whose value asks for what tracemesh does not do, values
  /// clamped, a repeated key, a missing Blobbyness.
  std::vector<std::string> warnings;
  /// For ses and skin: the one line saying which Gaussian surface is meshed instead. Empty for blobby.
  std::string substitution;
};

/// Reads the keys of `file` (see docs/nanoshaper.md for each). Errors (errc::invalid_input, "line N: Key: ..."):
/// a value honoured by tracemesh that does not parse (a number, true/false) or is out of range (Grid_scale ≤ 0,
/// Blobbyness outside [parameter_ranges::min_d, max_d]), a Surface tracemesh cannot mesh, an Operative_Mode other
/// than normal.
result<nanoshaper_job> read_job(const prm_file& file);

/// The mesh files the job writes, relative to its output folder: root + "triangulatedSurf" + .vert and .face,
/// .ply or .off.
std::vector<std::filesystem::path> mesh_files(const nanoshaper_job& job);

}  // namespace tracemesh::cli::nanoshaper
