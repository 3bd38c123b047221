// Fuzz target for the NanoShaper configuration reader (cli/nanoshaper: parse_prm, then read_job).
// Input: any bytes, as a .prm file. Checks, beyond "no crash": both steps fail only with errc::invalid_input; an
// accepted file has entries with non-empty keys free of blanks, in increasing line order; an accepted job asks for
// parameters within parameter_ranges and names at least one mesh file.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "cli/nanoshaper/nanoshaper_job.hpp"
#include "cli/nanoshaper/prm_file.hpp"

namespace {

void check_entries(const tracemesh::cli::nanoshaper::prm_file& file) {
  std::size_t previous_line = 0;
  for (const auto& entry : file.entries) {
    if (entry.key.empty() || entry.key.find_first_of(" \t") != std::string_view::npos) std::abort();
    if (entry.line <= previous_line) std::abort();
    previous_line = entry.line;
  }
}

void check_job(const tracemesh::cli::nanoshaper::nanoshaper_job& job) {
  using r = tracemesh::parameter_ranges;
  const tracemesh::mesh_params& p = job.params;
  const bool in_range = p.density >= r::min_density && p.density <= r::max_density && p.d >= r::min_d &&
                        p.d <= r::max_d && p.t0 >= r::min_t0 && p.t0 <= r::max_t0;
  if (!in_range || !(job.grid_scale > 0)) std::abort();
  if (tracemesh::cli::nanoshaper::mesh_files(job).empty()) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto file = tracemesh::cli::nanoshaper::parse_prm(text);
  if (!file) {
    if (file.error().code() != tracemesh::errc::invalid_input) std::abort();
    return 0;
  }
  check_entries(*file);
  const auto job = tracemesh::cli::nanoshaper::read_job(*file);
  if (!job) {
    if (job.error().code() != tracemesh::errc::invalid_input) std::abort();
    return 0;
  }
  check_job(*job);
  return 0;
}
