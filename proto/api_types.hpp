#pragma once
/// @file api_types.hpp
/// The request and response vocabulary of the HTTP API (proto/openapi.json): mesh parameters read from form
/// fields or query parameters, the error body, job states, and the mapping of core error codes onto HTTP.

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "core/mesher.hpp"
#include "core/status.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::proto {

/// Looks a request field up by name ("density", "d", "t0", "method", ..., "format"): its raw text, or nullopt when
/// absent.
using field_lookup = std::function<std::optional<std::string>(std::string_view)>;

/// The fields parse_mesh_params reads, as the service names them (form fields and query parameters) and as its
/// error messages name them. The CLI's options are the same names with '-' for '_' (--trace-degree).
///   density, d, t0            numbers (parse_parameter_number)
///   method                    "trace" | "lattice" (parse_method)
///   refine                    "none" | "full" (parse_refine)
///   cavities                  "keep" | "drop" (parse_cavity_mode)
///   trace_degree              an integer: trace_parameters::legendre_degree (M)
///   trace_step                a number: trace_parameters::step_fraction (h₁ / h̃)
///   trace_cos_bound           a number: trace_parameters::cos_bound (δ)
///   trace_extreme_tolerance   a number: trace_parameters::extreme_tolerance (ε)
inline constexpr std::array<std::string_view, 10> mesh_parameter_fields = {
    "density", "d", "t0", "method", "refine", "cavities", "trace_degree", "trace_step", "trace_cos_bound",
    "trace_extreme_tolerance"};

/// mesh_parameter_fields plus "format": every field a POST /mesh or POST /jobs request may carry besides "pqr".
inline constexpr std::array<std::string_view, 11> mesh_request_fields = {
    "density", "d", "t0", "method", "refine", "cavities", "trace_degree", "trace_step", "trace_cos_bound",
    "trace_extreme_tolerance", "format"};

/// Parses a parameter value: a finite decimal number in C syntax ("1", "1.0", "-0.5", "2e-3"), locale-free
/// (std::from_chars). Rejects the empty string, surrounding spaces, a leading '+', trailing bytes, hex, "nan" and
/// "inf" with errc::invalid_argument naming `field`. Equal numbers give equal doubles: "1" and "1.0" are the same
/// parameter (and so the same cache key).
result<double> parse_parameter_number(std::string_view field, std::string_view text);

/// Parses an integer parameter: parse_parameter_number, then the value must be a whole number in [min, max] ("10",
/// "10.0" and "1e1" are the same parameter). errc::invalid_argument naming `field` otherwise.
result<int> parse_parameter_integer(std::string_view field, std::string_view text, int min, int max);

/// Reads every field of mesh_parameter_fields through `lookup`. A missing field keeps mesh_params' default; a
/// present one must parse (numbers: parse_parameter_number; trace_degree: parse_parameter_integer; method and
/// refine: their exact lower-case names) and lie within parameter_ranges (checked by tracemesh::validate()).
/// The trace fields are validated whatever the method, so a request that is wrong for one method is wrong for both.
/// Errors: errc::invalid_argument whose message starts with the field's name. params.threads is left at its default.
result<mesh_params> parse_mesh_params(const field_lookup& lookup);

/// A POST /mesh or POST /jobs request apart from the uploaded file.
struct mesh_request {
  mesh_params params;
  mesh_format format = mesh_format::off;
};

/// parse_mesh_params plus the optional "format" field ("off" | "draco"; missing → `default_format`).
result<mesh_request> parse_mesh_request(const field_lookup& lookup, mesh_format default_format = mesh_format::off);

/// The shortest text that parses back to exactly `value` (std::to_chars shortest round trip), e.g. 1 → "1",
/// 0.1 → "0.1", -1 → "-1". Locale-free.
std::string canonical_number(double value);

/// One spelling per parameter set, for job ids (server/jobs/job_id.hpp), cache keys and logs:
///   "density=<n>;d=<n>;t0=<n>;method=<name>;refine=<name>"
/// followed, when the method is trace, by ";trace_degree=<n>;trace_step=<n>;trace_cos_bound=<n>;
/// trace_extreme_tolerance=<n>", numbers with canonical_number. The trace fields are left out for the lattice method
/// because they do not change its mesh (or its report); ";cavities=drop" follows when params.cavities is drop (keep,
/// the default, is left out); threads is excluded because it never changes the output.
/// An omitted request field and its default spelled out give the same string.
std::string canonical_parameters(const mesh_params& params);

/// {"error": {"code": <code>, "message": <message>}} — the body of every non-2xx JSON response.
nlohmann::json error_body(std::string_view code, std::string_view message);
/// error_body(errc_name(error.code()), error.message()).
nlohmann::json error_body(const status& error);

/// The HTTP status for a failed job or request: invalid_input, invalid_argument → 400; nothing_to_mesh → 422;
/// limit_exceeded → 413; cancelled → 503 (a generic fallback: the server answers a cancelled job by its reason,
/// 409 for DELETE, 504 past the per-job deadline, 503 at shutdown); io_error, internal_error → 500.
/// errc::ok → 200.
int http_status(errc code) noexcept;

/// Job lifecycle in GET /jobs/{id}: queued → running → done | failed | cancelled.
enum class job_state { queued, running, done, failed, cancelled };

/// "queued" | "running" | "done" | "failed" | "cancelled".
std::string_view job_state_name(job_state state) noexcept;
/// Inverse of job_state_name; errc::invalid_argument otherwise.
result<job_state> parse_job_state(std::string_view name);
/// True for done, failed and cancelled: the job will not change any more.
bool is_final(job_state state) noexcept;

}  // namespace tracemesh::proto
