#pragma once
// The member names of a JSON object, as a set to compare with the documented ones.
#include <set>
#include <string>

#include <nlohmann/json.hpp>

namespace tracemesh::testing {

inline std::set<std::string> keys_of(const nlohmann::json& object) {
  std::set<std::string> keys;
  for (const auto& item : object.items()) keys.insert(item.key());
  return keys;
}

}  // namespace tracemesh::testing
