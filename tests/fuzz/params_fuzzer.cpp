// Fuzz target for the request-parameter parser (proto::parse_mesh_request / parse_mesh_params).
// Input: a JSON object ({"density": "2", "d": -1, ...}; non-string values are passed as their JSON text) or,
// otherwise, key=value pairs separated by '&' or newlines, as a query string or form would give them.
// Checks, beyond "no crash": accepted parameters lie in parameter_ranges, and their canonical spelling parses
// back to the very same values.
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

void check_accepted(const tracemesh::mesh_params& params) {
  using r = tracemesh::parameter_ranges;
  const bool in_range = params.density >= r::min_density && params.density <= r::max_density &&
                        params.d >= r::min_d && params.d <= r::max_d && params.t0 >= r::min_t0 &&
                        params.t0 <= r::max_t0;
  if (!in_range) std::abort();
  const fields canonical = {{"density", tracemesh::proto::canonical_number(params.density)},
                            {"d", tracemesh::proto::canonical_number(params.d)},
                            {"t0", tracemesh::proto::canonical_number(params.t0)}};
  const auto again = tracemesh::proto::parse_mesh_params(lookup_in(canonical));
  if (!again || again->density != params.density || again->d != params.d || again->t0 != params.t0) std::abort();
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
