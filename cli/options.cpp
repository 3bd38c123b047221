#include "cli/options.hpp"

#include <algorithm>
#include <cctype>
#include <map>
#include <sstream>

#include <CLI/CLI.hpp>

#include "proto/api_types.hpp"

namespace tracemesh::cli {
namespace {

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

/// The raw text of each parameter option given, keyed by the API's field name.
using parameter_texts = std::map<std::string, std::string, std::less<>>;

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

void describe_options(CLI::App& app, cli_options& options, parameter_texts& texts, std::string& format_text,
                      std::string& report_text) {
  app.add_option("input", options.input, "PQR file, plain or gzip-compressed")->required();
  app.add_option("-o,--output", options.output,
                 "Mesh file to write; its extension (.off, .drc, .vert/.face) picks the format")
      ->required();
  app.add_option("--density", texts["density"], "Vertices per Å² (default 1)");
  app.add_option("--d", texts["d"], "Kernel decay rate d < 0 (default -1)");
  app.add_option("--t0", texts["t0"], "Isovalue t0 > 0 (default 1)");
  app.add_option("--threads", options.params.threads, "Worker threads, 0 = all cores (never changes the output)")
      ->check(CLI::Range(0U, max_threads));
  app.add_option("--format", format_text, "off | draco | msms (default: from the output's extension)");
  app.add_option("--report", report_text, "Write the JSON report to FILE, or to stdout with -");
  app.add_flag("-v,--verbose", options.verbose, "Print timings and a summary on stderr");
  app.set_version_flag("--version", std::string("tracemesh (engine ") + engine_version + ")");
}

/// The options CLI11 left as text: parameters through the service's parser, then the output format.
status finish_options(const CLI::App& app, cli_options& options, parameter_texts& texts,
                      const std::string& format_text, const std::string& report_text) {
  std::erase_if(texts, [&app](const auto& entry) { return app.count("--" + entry.first) == 0; });
  const unsigned threads = options.params.threads;
  const result<mesh_params> params = proto::parse_mesh_params(lookup_in(texts));
  if (!params) return params.error();
  options.params = *params;
  options.params.threads = threads;

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
  if (name == "off") return output_format::off;
  if (name == "draco") return output_format::draco;
  if (name == "msms") return output_format::msms;
  return status(errc::invalid_argument, "--format: expected off, draco or msms");
}

result<output_format> infer_output_format(const std::filesystem::path& output) {
  const std::string extension = lowercase(output.extension().string());
  if (extension == ".off") return output_format::off;
  if (extension == ".drc") return output_format::draco;
  if (extension == ".vert" || extension == ".face") return output_format::msms;
  return status(errc::invalid_argument,
                "cannot tell the format of " + output.filename().string() + " (use .off, .drc, .vert or --format)");
}

std::vector<std::filesystem::path> output_paths(const std::filesystem::path& output, output_format format) {
  if (format != output_format::msms) return {output};
  std::filesystem::path vert = output, face = output;
  return {vert.replace_extension(".vert"), face.replace_extension(".face")};
}

parsed_command_line parse_command_line(int argc, const char* const* argv) {
  CLI::App app("Meshes the Gaussian molecular surface of a PQR file.", "tracemesh");
  cli_options options;
  parameter_texts texts;
  std::string format_text, report_text;
  describe_options(app, options, texts, format_text, report_text);
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
