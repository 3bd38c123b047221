#pragma once
/// @file api_types.hpp
/// The request and response vocabulary of the HTTP API (proto/openapi.json): mesh parameters read from form
/// fields or query parameters, the error body, job states, and the mapping of core error codes onto HTTP.

#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "core/mesher.hpp"
#include "core/status.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::proto {

/// Looks a request field up by name ("density", "d", "t0", "format"): its raw text, or nullopt when absent.
using field_lookup = std::function<std::optional<std::string>(std::string_view)>;

/// Parses a parameter value: a finite decimal number in C syntax ("1", "1.0", "-0.5", "2e-3"), locale-free
/// (std::from_chars). Rejects the empty string, surrounding spaces, a leading '+', trailing bytes, hex, "nan" and
/// "inf" with errc::invalid_argument naming `field`. Equal numbers give equal doubles: "1" and "1.0" are the same
/// parameter (and so the same cache key).
result<double> parse_parameter_number(std::string_view field, std::string_view text);

/// Reads density, d and t0 through `lookup`. A missing field keeps mesh_params' default; a present one must
/// parse (parse_parameter_number) and lie within parameter_ranges (checked by tracemesh::validate()).
/// Errors: errc::invalid_argument whose message names the field. params.threads is left at its default.
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

/// "density=<n>;d=<n>;t0=<n>" with canonical_number: one spelling per parameter set, for cache keys and logs.
/// threads is excluded: it never changes the output.
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
