#include "proto/api_types.hpp"

#include <charconv>
#include <cmath>
#include <string>
#include <system_error>

#include "proto/detail/quote.hpp"

namespace tracemesh::proto {
namespace {

status bad_number(std::string_view field, std::string_view text, std::string_view why) {
  return {errc::invalid_argument,
          std::string(field) + ": expected a finite decimal number, got " + detail::quoted(text) + " (" +
              std::string(why) + ")"};
}

/// Overwrites `target` with the parsed field when `lookup` has it.
status read_number_field(const field_lookup& lookup, std::string_view field, double& target) {
  const std::optional<std::string> text = lookup(field);
  if (!text) return status::success();
  const result<double> value = parse_parameter_number(field, *text);
  if (!value) return value.error();
  target = *value;
  return status::success();
}

status read_integer_field(const field_lookup& lookup, std::string_view field, int min, int max, int& target) {
  const std::optional<std::string> text = lookup(field);
  if (!text) return status::success();
  const result<int> value = parse_parameter_integer(field, *text, min, max);
  if (!value) return value.error();
  target = *value;
  return status::success();
}

/// A name field ("method", "refine"): `parse` must accept the exact text.
template <typename Enum>
status read_name_field(const field_lookup& lookup, std::string_view field, bool (*parse)(std::string_view, Enum&),
                       std::string_view expected, Enum& target) {
  const std::optional<std::string> text = lookup(field);
  if (!text) return status::success();
  if (!parse(*text, target)) {
    return {errc::invalid_argument,
            std::string(field) + ": expected " + std::string(expected) + ", got " + detail::quoted(*text)};
  }
  return status::success();
}

}  // namespace

result<double> parse_parameter_number(std::string_view field, std::string_view text) {
  if (text.empty()) return bad_number(field, text, "empty");
  double value = 0;
  const char* const end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value, std::chars_format::general);
  if (error == std::errc::result_out_of_range) return bad_number(field, text, "out of range");
  if (error != std::errc{}) return bad_number(field, text, "not a number");
  if (stop != end) return bad_number(field, text, "trailing characters");
  if (!std::isfinite(value)) return bad_number(field, text, "not finite");
  return value;
}

result<int> parse_parameter_integer(std::string_view field, std::string_view text, int min, int max) {
  const result<double> value = parse_parameter_number(field, text);
  if (!value) return value.error();
  // Compared as doubles before any conversion: 1e300 must not reach an int.
  if (*value != std::trunc(*value) || *value < min || *value > max) {
    return status{errc::invalid_argument, std::string(field) + " must be an integer in [" + std::to_string(min) +
                                              ", " + std::to_string(max) + "], got " + canonical_number(*value)};
  }
  return static_cast<int>(*value);
}

result<mesh_params> parse_mesh_params(const field_lookup& lookup) {
  mesh_params params;
  trace_parameters& trace = params.trace;
  for (const auto& [field, target] : {std::pair<std::string_view, double*>{"density", &params.density},
                                      std::pair<std::string_view, double*>{"d", &params.d},
                                      std::pair<std::string_view, double*>{"t0", &params.t0}}) {
    if (const status read = read_number_field(lookup, field, *target); !read) return read;
  }
  if (const status read = read_name_field(lookup, "method", parse_method, "trace or lattice", params.method); !read) {
    return read;
  }
  if (const status read = read_name_field(lookup, "refine", parse_refine, "none or full", params.refine); !read) {
    return read;
  }
  if (const status read = read_name_field(lookup, "cavities", parse_cavity_mode, "keep or drop", params.cavities);
      !read) {
    return read;
  }
  using r = parameter_ranges;
  if (const status read = read_integer_field(lookup, "trace_degree", r::min_legendre_degree, r::max_legendre_degree,
                                             trace.legendre_degree);
      !read) {
    return read;
  }
  for (const auto& [field, target] :
       {std::pair<std::string_view, double*>{"trace_step", &trace.step_fraction},
        std::pair<std::string_view, double*>{"trace_cos_bound", &trace.cos_bound},
        std::pair<std::string_view, double*>{"trace_extreme_tolerance", &trace.extreme_tolerance}}) {
    if (const status read = read_number_field(lookup, field, *target); !read) return read;
  }
  if (const status valid = validate(params); !valid) return valid;
  return params;
}

result<mesh_request> parse_mesh_request(const field_lookup& lookup, mesh_format default_format) {
  const result<mesh_params> params = parse_mesh_params(lookup);
  if (!params) return params.error();
  mesh_request request{*params, default_format};
  if (const std::optional<std::string> name = lookup("format")) {
    const result<mesh_format> format = parse_mesh_format(*name);
    if (!format) return format.error();
    request.format = *format;
  }
  return request;
}

std::string canonical_number(double value) {
  char buffer[32];
  if (value == 0) value = 0;  // -0 and 0 are the same parameter
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, written.ptr);
}

std::string canonical_parameters(const mesh_params& params) {
  std::string text = "density=" + canonical_number(params.density) + ";d=" + canonical_number(params.d) +
                     ";t0=" + canonical_number(params.t0) + ";method=" + method_name(params.method) +
                     ";refine=" + refine_name(params.refine);
  if (params.cavities == cavity_mode::drop) text += std::string(";cavities=") + cavity_mode_name(params.cavities);
  if (params.method == mesh_method::trace) {
    const trace_parameters& trace = params.trace;
    text += ";trace_degree=" + std::to_string(trace.legendre_degree) +
            ";trace_step=" + canonical_number(trace.step_fraction) +
            ";trace_cos_bound=" + canonical_number(trace.cos_bound) +
            ";trace_extreme_tolerance=" + canonical_number(trace.extreme_tolerance);
  }
  return text;
}

nlohmann::json error_body(std::string_view code, std::string_view message) {
  return {{"error", {{"code", code}, {"message", message}}}};
}

nlohmann::json error_body(const status& error) { return error_body(errc_name(error.code()), error.message()); }

int http_status(errc code) noexcept {
  switch (code) {
    case errc::ok: return 200;
    case errc::invalid_input: return 400;
    case errc::invalid_argument: return 400;
    case errc::nothing_to_mesh: return 422;
    case errc::limit_exceeded: return 413;
    case errc::cancelled: return 503;
    case errc::io_error: return 500;
    case errc::internal_error: return 500;
    case errc::unresolvable_input: return 422;
  }
  return 500;
}

std::string_view job_state_name(job_state state) noexcept {
  switch (state) {
    case job_state::queued: return "queued";
    case job_state::running: return "running";
    case job_state::done: return "done";
    case job_state::failed: return "failed";
    case job_state::cancelled: return "cancelled";
  }
  return "failed";
}

result<job_state> parse_job_state(std::string_view name) {
  for (const job_state state :
       {job_state::queued, job_state::running, job_state::done, job_state::failed, job_state::cancelled}) {
    if (job_state_name(state) == name) return state;
  }
  return status(errc::invalid_argument, "job state: unknown " + detail::quoted(name));
}

bool is_final(job_state state) noexcept {
  return state == job_state::done || state == job_state::failed || state == job_state::cancelled;
}

}  // namespace tracemesh::proto
