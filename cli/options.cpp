#include "cli/options.hpp"

#include <algorithm>
#include <cctype>
#include <map>
#include <sstream>

#include <CLI/CLI.hpp>

#include "proto/api_types.hpp"
#include "tracemesh_build_info.hpp"

namespace tracemesh::cli {
namespace {

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

/// The raw text of each parameter option given, keyed by the API's field name.
using parameter_texts = std::map<std::string, std::string, std::less<>>;

/// The option of an API field: "trace_degree" → "--trace-degree".
std::string option_name(std::string_view field) {
  std::string option = "--" + std::string(field);
  std::replace(option.begin(), option.end(), '_', '-');
  return option;
}

/// A parameter error names the API field first ("trace_degree must be ..."): name it as the option is spelled on
/// this command line instead ("trace-degree must be ..."); density, d, t0, method and refine read the same.
std::string in_option_terms(const std::string& message) {
  for (const std::string_view field : proto::mesh_parameter_fields) {
    const bool names_field = message.size() > field.size() && message.compare(0, field.size(), field) == 0 &&
                             (message[field.size()] == ':' || message[field.size()] == ' ');
    if (names_field) return option_name(field).substr(2) + message.substr(field.size());
  }
  return message;
}

proto::field_lookup lookup_in(const parameter_texts& texts) {
  return [&texts](std::string_view name) -> std::optional<std::string> {
    const auto found = texts.find(name);
    if (found == texts.end()) return std::nullopt;
    return found->second;
  };
}

parsed_command_line usage_error(const std::string& message) {
  parsed_command_line parsed;
  parsed.exit_code = 2;
  parsed.error = message + " (see tracemesh --help)";
  return parsed;
}

/// "[lo, hi], default x" from parameter_ranges and mesh_params{}, so the help never disagrees with the engine.
std::string range_and_default(double lo, double hi, double fallback) {
  return "in [" + proto::canonical_number(lo) + ", " + proto::canonical_number(hi) +
         "], default " + proto::canonical_number(fallback);
}

void describe_options(CLI::App& app, cli_options& options, parameter_texts& texts, std::string& format_text,
                      std::string& report_text) {
  using r = parameter_ranges;
  const mesh_params defaults;
  const trace_parameters& trace = defaults.trace;
  app.add_option("input", options.input,
                 "Molecule file: PQR, PDB, mmCIF or xyzr (told from the content), plain or gzip-compressed")
      ->required();
  app.add_option("-o,--output", options.output,
                 "Mesh file to write; its extension (.off, .drc, .glb, .ply, .vert/.face) picks the format")
      ->required();
  app.add_option("--density", texts["density"],
                 "Vertices per Å², " + range_and_default(r::min_density, r::max_density, defaults.density))
      ->type_name("F");
  app.add_option("--d", texts["d"], "Kernel decay rate d, " + range_and_default(r::min_d, r::max_d, defaults.d))
      ->type_name("F");
  app.add_option("--t0", texts["t0"], "Isovalue t0, " + range_and_default(r::min_t0, r::max_t0, defaults.t0))
      ->type_name("F");
  app.add_option("--method", texts["method"],
                 std::string("trace (the paper's traced contours) | lattice (marching tetrahedra); default ") +
                     method_name(defaults.method))
      ->type_name("trace|lattice");
  app.add_option("--refine", texts["refine"],
                 std::string("full (quality pass) | none (the polygons' triangles as they are); default ") +
                     refine_name(defaults.refine))
      ->type_name("none|full");
  app.add_option("--cavities", texts["cavities"],
                 std::string("keep | drop (remove components enclosed by another: inner cavities); default ") +
                     cavity_mode_name(defaults.cavities))
      ->type_name("keep|drop");
  app.add_option("--trace-degree", texts["trace_degree"],
                 "Trace: Legendre degree M along each line, an integer in [" +
                     std::to_string(r::min_legendre_degree) + ", " + std::to_string(r::max_legendre_degree) +
                     "], default " + std::to_string(trace.legendre_degree))
      ->type_name("N");
  app.add_option("--trace-step", texts["trace_step"],
                 "Trace: step h₁ as a fraction of the line spacing h̃, " +
                     range_and_default(r::min_trace_step_fraction, r::max_trace_step_fraction, trace.step_fraction))
      ->type_name("F");
  app.add_option("--trace-cos-bound", texts["trace_cos_bound"],
                 "Trace: δ, cosine of the largest normal turn per step, " +
                     range_and_default(r::min_trace_cos_bound, r::max_trace_cos_bound, trace.cos_bound))
      ->type_name("F");
  app.add_option("--trace-extreme-tolerance", texts["trace_extreme_tolerance"],
                 "Trace: ε, |φ_x| < ε·|∇φ| marks an extreme point in x, " +
                     range_and_default(r::min_extreme_tolerance, r::max_extreme_tolerance, trace.extreme_tolerance))
      ->type_name("F");
  app.add_option("--format-in", texts["format_in"],
                 "Input format pqr | pdb | mmcif | xyzr (default: the file extension, else detected from the content)");
  app.add_option("--radii", texts["radii"], "PDB/mmCIF: van der Waals radii, bondi (default) | mantina");
  app.add_option("--hydrogens", texts["hydrogens"], "PDB/mmCIF: keep (default) | drop hydrogen atoms");
  app.add_option("--waters", texts["waters"], "PDB/mmCIF: keep | drop (default) water molecules");
  app.add_option("--ligands", texts["ligands"], "PDB/mmCIF: keep (default) | drop ligands, ions, cofactors");
  app.add_option("--assembly", texts["assembly"],
                 "PDB/mmCIF: asu (default: the file's own coordinates) | the id of a biological assembly the file "
                 "lists (REMARK 350 BIOMOLECULE, _pdbx_struct_assembly), built from its symmetry operators")
      ->type_name("ID|asu");
  app.add_option("--threads", options.params.threads, "Worker threads, 0 = all cores (never changes the output)")
      ->check(CLI::Range(0U, max_threads));
  app.add_option("--format", format_text,
                 proto::format_names_text() + " or msms (default: from the output's extension; .glb is glb)");
  app.add_option("--report", report_text, "Write the JSON report to FILE, or to stdout with -");
  app.add_flag("-v,--verbose", options.verbose, "Print timings and a summary on stderr");
  app.set_version_flag("--version", build_info::version_line("tracemesh"));
}

/// The options CLI11 left as text: parameters through the service's parser, then the output format.
status finish_options(const CLI::App& app, cli_options& options, parameter_texts& texts,
                      const std::string& format_text, const std::string& report_text) {
  std::erase_if(texts, [&app](const auto& entry) { return app.count(option_name(entry.first)) == 0; });
  const unsigned threads = options.params.threads;
  const result<mesh_params> params = proto::parse_mesh_params(lookup_in(texts));
  if (!params) return {params.error().code(), in_option_terms(params.error().message())};
  options.params = *params;
  options.params.threads = threads;
  const result<structure_options> input_options = parse_structure_options(lookup_in(texts));
  if (!input_options) {
    // "format_in must be ..." → "--format-in must be ...": the field as this command line spells it.
    const std::string message = input_options.error().message();
    const std::size_t field_end = std::min(message.find(' '), message.size());
    return {input_options.error().code(), option_name(message.substr(0, field_end)) + message.substr(field_end)};
  }
  options.input_options = *input_options;

  const result<output_format> format =
      app.count("--format") == 0 ? infer_output_format(options.output) : parse_output_format(format_text);
  if (!format) return format.error();
  options.format = *format;
  if (app.count("--report") > 0) {
    if (report_text.empty()) return {errc::invalid_argument, "--report: expected a file name or -"};
    options.report = report_text;
  }
  return status::success();
}

}  // namespace

result<output_format> parse_output_format(std::string_view name) {
  if (name == "msms") return output_format{.msms = true};
  const result<proto::mesh_format> format = proto::parse_mesh_format(name);
  if (!format) return status(errc::invalid_argument, "--format: expected " + proto::format_names_text() + " or msms");
  return output_format{.mesh = *format};
}

result<output_format> infer_output_format(const std::filesystem::path& output) {
  const std::string extension = lowercase(output.extension().string());
  if (extension == ".vert" || extension == ".face") return output_format{.msms = true};
  if (const result<proto::mesh_format> format = proto::format_for_extension(extension)) {
    return output_format{.mesh = *format};
  }
  return status(errc::invalid_argument, "cannot tell the format of " + output.filename().string() +
                                            " (use .off, .drc, .glb, .ply, .vert or --format)");
}

std::vector<std::filesystem::path> output_paths(const std::filesystem::path& output, output_format format) {
  if (!format.msms) return {output};
  std::filesystem::path vert = output, face = output;
  return {vert.replace_extension(".vert"), face.replace_extension(".face")};
}

parsed_command_line parse_command_line(int argc, const char* const* argv) {
  CLI::App app("Meshes the Gaussian molecular surface of a PQR, PDB, mmCIF or xyzr file.", "tracemesh");
  cli_options options;
  parameter_texts texts;
  std::string format_text, report_text;
  describe_options(app, options, texts, format_text, report_text);
  app.footer("Also: tracemesh nanoshaper [CONF.prm] runs a NanoShaper configuration (as does tracemesh invoked as "
             "NanoShaper); see docs/nanoshaper.md");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& success) {  // --help or --version
    std::ostringstream out, err;
    parsed_command_line parsed;
    parsed.exit_code = app.exit(success, out, err);
    parsed.standard_output = out.str();
    return parsed;
  } catch (const CLI::ParseError& error) {
    return usage_error(error.what());
  }
  if (const status finished = finish_options(app, options, texts, format_text, report_text); !finished) {
    return usage_error(finished.message());
  }
  parsed_command_line parsed;
  parsed.options = std::move(options);
  return parsed;
}

}  // namespace tracemesh::cli
