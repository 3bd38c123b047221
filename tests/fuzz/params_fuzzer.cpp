// Fuzz target for the request-parameter parser (proto::parse_mesh_request / parse_mesh_params).
// Input: a JSON object ({"density": "2", "d": -1, ...}; non-string values are passed as their JSON text) or,
// otherwise, key=value pairs separated by '&' or newlines, as a query string or form would give them.
// Checks, beyond "no crash": accepted parameters lie in parameter_ranges (the trace parameters included, whatever
// the method), and their canonical spelling (canonical_parameters, split on ';') parses back to parameters with the
// same canonical spelling and the very same values.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "proto/api_types.hpp"

namespace {

using fields = std::map<std::string, std::string, std::less<>>;

fields fields_from_json(const nlohmann::json& object) {
  fields parsed;
  for (const auto& item : object.items()) {
    parsed[item.key()] = item.value().is_string() ? item.value().get<std::string>() : item.value().dump();
  }
  return parsed;
}

fields fields_from_pairs(std::string_view text) {
  fields parsed;
  while (!text.empty()) {
    const std::size_t end = text.find_first_of("&\n");
    const std::string_view pair = text.substr(0, end);
    const std::size_t equals = pair.find('=');
    if (equals != std::string_view::npos) parsed[std::string(pair.substr(0, equals))] = pair.substr(equals + 1);
    if (end == std::string_view::npos) break;
    text.remove_prefix(end + 1);
  }
  return parsed;
}

tracemesh::proto::field_lookup lookup_in(const fields& values) {
  return [&values](std::string_view name) -> std::optional<std::string> {
    const auto found = values.find(name);
    if (found == values.end()) return std::nullopt;
    return found->second;
  };
}

/// "a=1;b=2" → {a: 1, b: 2}.
fields fields_from_canonical(std::string_view text) {
  fields parsed;
  while (!text.empty()) {
    const std::size_t end = text.find(';');
    const std::string_view pair = text.substr(0, end);
    const std::size_t equals = pair.find('=');
    if (equals == std::string_view::npos) std::abort();  // canonical_parameters writes name=value pairs only
    parsed[std::string(pair.substr(0, equals))] = pair.substr(equals + 1);
    if (end == std::string_view::npos) break;
    text.remove_prefix(end + 1);
  }
  return parsed;
}

void check_accepted(const tracemesh::mesh_params& params) {
  using r = tracemesh::parameter_ranges;
  const tracemesh::trace_parameters& t = params.trace;
  const bool in_range = params.density >= r::min_density && params.density <= r::max_density &&
                        params.d >= r::min_d && params.d <= r::max_d && params.t0 >= r::min_t0 &&
                        params.t0 <= r::max_t0 && t.legendre_degree >= r::min_legendre_degree &&
                        t.legendre_degree <= r::max_legendre_degree && t.step_fraction >= r::min_trace_step_fraction &&
                        t.step_fraction <= r::max_trace_step_fraction && t.cos_bound >= r::min_trace_cos_bound &&
                        t.cos_bound <= r::max_trace_cos_bound && t.extreme_tolerance >= r::min_extreme_tolerance &&
                        t.extreme_tolerance <= r::max_extreme_tolerance;
  if (!in_range) std::abort();
  const std::string canonical = tracemesh::proto::canonical_parameters(params);
  const fields spelled = fields_from_canonical(canonical);
  const auto again = tracemesh::proto::parse_mesh_params(lookup_in(spelled));
  if (!again || tracemesh::proto::canonical_parameters(*again) != canonical) std::abort();
  if (again->density != params.density || again->d != params.d || again->t0 != params.t0 ||
      again->method != params.method || again->refine != params.refine) {
    std::abort();
  }
  const tracemesh::trace_parameters& u = again->trace;
  const bool same_trace = u.legendre_degree == t.legendre_degree && u.step_fraction == t.step_fraction &&
                          u.cos_bound == t.cos_bound && u.extreme_tolerance == t.extreme_tolerance;
  if (params.method == tracemesh::mesh_method::trace && !same_trace) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  fields values;
  const nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_object()) {
    values = fields_from_json(json);
  } else {
    values = fields_from_pairs(text);
  }
  const auto request = tracemesh::proto::parse_mesh_request(lookup_in(values));
  if (request) {
    check_accepted(request->params);
  } else if (request.error().code() != tracemesh::errc::invalid_argument) {
    std::abort();  // bad parameters are invalid_argument, nothing else
  }
  return 0;
}
