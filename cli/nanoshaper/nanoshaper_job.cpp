#include "cli/nanoshaper/nanoshaper_job.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>
#include <optional>
#include <string_view>

#include "cli/options.hpp"
#include "core/io/pqr_text.hpp"
#include "core/limits.hpp"
#include "proto/api_types.hpp"

namespace tracemesh::cli::nanoshaper {
namespace {

/// NanoShaper keys that tune its own grid, ray casting or smoothing and have no counterpart in tracemesh (whose
/// mesh is refined and free of duplicated vertices whatever they say): accepted with any value, without a warning.
constexpr auto tuning_keys = std::to_array<std::string_view>({
    "Grid_perfil", "Build_status_map", "Smooth_Mesh", "Check_duplicated_vertices", "Accurate_Triangulation",
    "Load_Balancing", "Print_Available_Surfaces", "Patch_Based_Algorithm", "Analytical_Ray_Vs_Torus_Intersection",
    "Force_Serial_Build", "Optimize_Grids", "Skip_Mem_CleanUp", "Skin_Fast_Projection", "Keep_Water_Shaped_Cavities",
    "Conditional_Volume_Filling_Value", "Max_Probes_Self_Intersections", "Self_Intersections_Grid_Coefficient",
    "Max_mesh_auxiliary_grid_size", "Max_mesh_auxiliary_grid_2d_size", "Max_mesh_patches_per_auxiliary_grid_cell",
    "Max_mesh_patches_per_auxiliary_grid_2d_cell", "Max_ses_patches_auxiliary_grid_size",
    "Max_ses_patches_auxiliary_grid_2d_size", "Max_ses_patches_per_auxiliary_grid_cell",
    "Max_ses_patches_per_auxiliary_grid_2d_cell", "Max_skin_patches_auxiliary_grid_size",
    "Max_skin_patches_auxiliary_grid_2d_size", "Max_skin_patches_per_auxiliary_grid_cell",
    "Max_skin_patches_per_auxiliary_grid_2d_cell", "Sys_Name", "Seed", "Debug_Internals", "Domain_Shrinkage",
    "Parallel_Buildup_Halo_Thickness", "Collect_face_intersections", "Collect_Face_Intersections",
    // Operative_Mode = pockets only, which read_job refuses: harmless in a normal-mode file.
    "Num_Wat_Pocket", "Pockets_And_Cavities", "Link_Pockets", "Pocket_Radius_Big", "Pocket_Radius_Small",
    "Pocket_Radius_Link"});

/// Switches for what NanoShaper computes besides the mesh (maps, cavities, ray-tracing scenes): false is what
/// tracemesh does; true is warned about as unsupported.
constexpr auto unsupported_when_true = std::to_array<std::string_view>({
    "Build_epsilon_maps", "Save_eps_maps", "Save_Status_map", "Save_PovRay", "Tri2Balls",
    "Cavity_Detection_Filling", "Save_Cavities", "Save_bgps", "Save_ideb_map", "Project_boundary_grid_points",
    "Multi_Dielectric"});

/// The keys read_job uses, each for its value.
constexpr auto honoured_keys = std::to_array<std::string_view>({
    "XYZR_FileName", "Surface", "Blobbyness", "Grid_scale", "Number_thread", "Save_Mesh_MSMS_Format",
    "Save_Mesh_PLY_Format", "Compute_Vertex_Normals", "Vertex_Atom_Info", "Root_FileName", "Output_Folder",
    "Operative_Mode", "Triangulation", "Probe_Radius", "Skin_Surface_Parameter", "Max_Num_Atoms"});

template <std::size_t n>
bool contains(const std::array<std::string_view, n>& keys, std::string_view key) {
  return std::find(keys.begin(), keys.end(), key) != keys.end();
}

status value_error(const prm_entry& entry, const std::string& what) {
  return {errc::invalid_input, "line " + std::to_string(entry.line) + ": " + entry.key + ": " + what};
}

/// `text` as a message quotes it: at most detail::max_quoted_bytes, in quotes. (Appended piece by piece: g++ 12
/// raises a false -Wrestrict on `"'" + std::string`.)
std::string in_quotes(std::string_view text) {
  std::string out = "'";
  out += detail::quote_bytes(text);
  out += '\'';
  return out;
}

std::string quoted_value(const prm_entry& entry) { return in_quotes(entry.value); }

std::string uppercase(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return out;
}

/// NanoShaper's spellings of a boolean (its reader takes any other text as true; tracemesh refuses it).
result<bool> parse_bool(const prm_entry& entry) {
  const std::string value = uppercase(entry.value);
  for (const char* no : {"FALSE", "F", "NO", "N", "0", "NONE"}) {
    if (value == no) return false;
  }
  for (const char* yes : {"TRUE", "T", "YES", "Y", "1", "-1"}) {
    if (value == yes) return true;
  }
  return value_error(entry, "expected true or false, got " + quoted_value(entry));
}

/// A finite decimal number, read as the molecule readers read theirs.
result<double> parse_number(const prm_entry& entry) {
  const detail::parsed_number number = detail::parse_number(entry.value);
  if (number.error != detail::number_error::none) {
    return value_error(entry, "expected a number, got " + quoted_value(entry));
  }
  return number.value;
}

/// The last entry of each key (NanoShaper keeps the last of a repeated key); a warning for each repetition.
std::map<std::string, const prm_entry*, std::less<>> last_entries(const prm_file& file,
                                                                  std::vector<std::string>& warnings) {
  std::map<std::string, const prm_entry*, std::less<>> last;
  for (const prm_entry& entry : file.entries) {
    auto [it, inserted] = last.try_emplace(entry.key, &entry);
    if (!inserted) {
      warnings.push_back("line " + std::to_string(entry.line) + ": " + entry.key + " repeated; line " +
                         std::to_string(it->second->line) + "'s value is replaced, as NanoShaper does");
      it->second = &entry;
    }
  }
  return last;
}

/// The keys read_job does not use, in file order: unknown ones, and switches asking for what tracemesh does not
/// compute. `last` holds the entry of each key that counts.
status warn_about_other_keys(const prm_file& file, const std::map<std::string, const prm_entry*, std::less<>>& last,
                             std::vector<std::string>& warnings) {
  for (const prm_entry& entry : file.entries) {
    const std::string& key = entry.key;
    if (last.at(key) != &entry || contains(honoured_keys, key) || contains(tuning_keys, key)) continue;
    const std::string where = "line " + std::to_string(entry.line) + ": ";
    if (contains(unsupported_when_true, key)) {
      const result<bool> on = parse_bool(entry);
      if (!on) return on.error();
      if (*on) warnings.push_back(where + key + " = " + entry.value + " is not supported (ignored)");
      continue;
    }
    warnings.push_back(where + "unknown key " + key + " (ignored)");
  }
  return status::success();
}

class job_reader {
 public:
  job_reader(const prm_file& file, nanoshaper_job& job)
      : file_(file), job_(job), entries_(last_entries(file, job.warnings)) {}

  status read() {
    if (status checked = warn_about_other_keys(file_, entries_, job_.warnings); !checked) return checked;
    using part_reader = status (job_reader::*)();
    for (const part_reader read_part :
         {&job_reader::read_mode, &job_reader::read_surface, &job_reader::read_grid_scale, &job_reader::read_threads,
          &job_reader::read_outputs, &job_reader::read_limits}) {
      if (status part = (this->*read_part)(); !part) return part;
    }
    job_.xyzr = text("XYZR_FileName").value_or(default_xyzr_file);
    if (job_.xyzr.empty()) return value_error(*entries_.at("XYZR_FileName"), "expected a file name");
    job_.root = text("Root_FileName").value_or("");
    job_.output_folder = text("Output_Folder").value_or("");
    return status::success();
  }

 private:
  const prm_entry* find(std::string_view key) const {
    const auto it = entries_.find(key);
    return it == entries_.end() ? nullptr : it->second;
  }
  std::optional<std::string> text(std::string_view key) const {
    const prm_entry* entry = find(key);
    return entry ? std::optional<std::string>(entry->value) : std::nullopt;
  }
  /// The boolean of `key`, or `fallback` when it is absent.
  status read_bool(std::string_view key, bool fallback, bool& out) const {
    out = fallback;
    if (const prm_entry* entry = find(key)) {
      const result<bool> value = parse_bool(*entry);
      if (!value) return value.error();
      out = *value;
    }
    return status::success();
  }
  status read_number(std::string_view key, double fallback, double& out) const {
    out = fallback;
    if (const prm_entry* entry = find(key)) {
      const result<double> value = parse_number(*entry);
      if (!value) return value.error();
      out = *value;
    }
    return status::success();
  }

  status read_mode() {
    if (const prm_entry* mode = find("Operative_Mode"); mode && mode->value != "normal") {
      return value_error(*mode, "only normal is supported (tracemesh meshes the surface), got " + quoted_value(*mode));
    }
    bool triangulate = true;
    if (status read = read_bool("Triangulation", true, triangulate); !read) return read;
    if (!triangulate) {
      job_.warnings.push_back("line " + std::to_string(find("Triangulation")->line) +
                              ": Triangulation = false is ignored: tracemesh always writes the triangulated surface");
    }
    return status::success();
  }

  status read_surface() {
    const prm_entry* entry = find("Surface");
    const std::string name = entry ? entry->value : "ses";  // NanoShaper's default
    if (name == "blobby") return read_blobby();
    if (name != "ses" && name != "skin") {
      const std::string what = in_quotes(name) + " is not a molecular surface tracemesh meshes (ses, skin or blobby)";
      return entry ? value_error(*entry, what) : status(errc::invalid_input, "Surface: " + what);
    }
    job_.surface = name == "ses" ? surface_kind::ses : surface_kind::skin;
    const gaussian_surface substitute = name == "ses" ? ses_substitute : skin_substitute;
    job_.params.d = substitute.d;
    job_.params.t0 = substitute.t0;
    job_.substitution = "Surface = " + name + ": meshing the Gaussian surface d = " +
                        proto::canonical_number(substitute.d) + ", t0 = " + proto::canonical_number(substitute.t0) +
                        " in its place (docs/nanoshaper.md: how close it comes to NanoShaper's " +
                        (name == "ses" ? "SES" : "skin surface") + ")";
    const bool ses = name == "ses";
    const char* parameter = ses ? "Probe_Radius" : "Skin_Surface_Parameter";
    const double measured_at = ses ? substitute_probe_radius : substitute_skin_parameter;
    double given = measured_at;
    if (status read = read_number(parameter, measured_at, given); !read) return read;
    if (given != measured_at) {
      job_.warnings.push_back(std::string(parameter) + " = " + find(parameter)->value +
                              " does not change the Gaussian surface (its d and t0 were chosen for " +
                              proto::canonical_number(measured_at) + ")");
    }
    return status::success();
  }

  status read_blobby() {
    job_.surface = surface_kind::blobby;
    const prm_entry* entry = find("Blobbyness");
    if (!entry) {
      job_.warnings.push_back("Surface = blobby without Blobbyness: using NanoShaper's default " +
                              proto::canonical_number(default_blobbyness) + " (is the key misspelt?)");
      job_.params.d = default_blobbyness;
    } else {
      const result<double> value = parse_number(*entry);
      if (!value) return value.error();
      if (!(*value >= parameter_ranges::min_d && *value <= parameter_ranges::max_d)) {
        return value_error(*entry, "must be in [" + proto::canonical_number(parameter_ranges::min_d) + ", " +
                                       proto::canonical_number(parameter_ranges::max_d) + "], got " + entry->value);
      }
      job_.params.d = *value;
    }
    job_.params.t0 = 1.0;  // NanoShaper's Blobby surface is the level 1 of the same sum of kernels
    return status::success();
  }

  status read_grid_scale() {
    if (status read = read_number("Grid_scale", default_grid_scale, job_.grid_scale); !read) return read;
    if (!(job_.grid_scale > 0)) {
      return value_error(*find("Grid_scale"), "must be > 0, got " + find("Grid_scale")->value);
    }
    const double wanted = density_per_grid_scale_squared * job_.grid_scale * job_.grid_scale;
    job_.params.density = std::clamp(wanted, parameter_ranges::min_density, parameter_ranges::max_density);
    if (job_.params.density != wanted) {
      job_.warnings.push_back("Grid_scale = " + proto::canonical_number(job_.grid_scale) + " asks for " +
                              proto::canonical_number(wanted) + " vertices per Å²; tracemesh meshes at " +
                              proto::canonical_number(job_.params.density));
    }
    return status::success();
  }

  status read_threads() {
    double threads = -1;  // NanoShaper's default: every core
    if (status read = read_number("Number_thread", -1, threads); !read) return read;
    if (threads != std::floor(threads)) return value_error(*find("Number_thread"), "expected an integer");
    job_.params.threads = threads <= 0 ? 0U : static_cast<unsigned>(std::min<double>(threads, max_threads));
    return status::success();
  }

  status read_outputs() {
    bool msms = false, ply = false;
    for (status read : {read_bool("Save_Mesh_MSMS_Format", false, msms), read_bool("Save_Mesh_PLY_Format", false, ply),
                        read_bool("Compute_Vertex_Normals", false, job_.off_normals),
                        read_bool("Vertex_Atom_Info", false, job_.off_atoms)}) {
      if (!read) return read;
    }
    job_.format = ply ? mesh_file_format::ply : msms ? mesh_file_format::msms : mesh_file_format::off;
    return status::success();
  }

  status read_limits() {
    double max_atoms = -1;
    if (status read = read_number("Max_Num_Atoms", -1, max_atoms); !read) return read;
    if (max_atoms > 0) {
      job_.warnings.push_back("Max_Num_Atoms = " + find("Max_Num_Atoms")->value +
                              " is not supported: every atom of the file is meshed");
    }
    return status::success();
  }

  const prm_file& file_;
  nanoshaper_job& job_;
  std::map<std::string, const prm_entry*, std::less<>> entries_;
};

}  // namespace

result<nanoshaper_job> read_job(const prm_file& file) {
  nanoshaper_job job;
  if (status read = job_reader(file, job).read(); !read) return read;
  return job;
}

std::vector<std::filesystem::path> mesh_files(const nanoshaper_job& job) {
  const std::string stem = job.root + mesh_file_stem;
  switch (job.format) {
    case mesh_file_format::msms: return {stem + ".vert", stem + ".face"};
    case mesh_file_format::ply: return {stem + ".ply"};
    case mesh_file_format::off: break;
  }
  return {stem + ".off"};
}

}  // namespace tracemesh::cli::nanoshaper
