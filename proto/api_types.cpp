#include "proto/api_types.hpp"

#include <charconv>
#include <cmath>
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

result<mesh_params> parse_mesh_params(const field_lookup& lookup) {
  mesh_params params;
  for (const auto& [field, target] : {std::pair<std::string_view, double*>{"density", &params.density},
                                      std::pair<std::string_view, double*>{"d", &params.d},
                                      std::pair<std::string_view, double*>{"t0", &params.t0}}) {
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
  return "density=" + canonical_number(params.density) + ";d=" + canonical_number(params.d) +
         ";t0=" + canonical_number(params.t0);
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
