#include "proto/openapi.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "proto/api_types.hpp"
#include "proto/report_json.hpp"

namespace tracemesh::proto {
namespace {

nlohmann::json document() { return nlohmann::json::parse(openapi_document()); }

const nlohmann::json& schema(const nlohmann::json& doc, const std::string& name) {
  return doc.at("components").at("schemas").at(name);
}

std::set<std::string> keys_of(const nlohmann::json& object) {
  std::set<std::string> keys;
  for (const auto& item : object.items()) keys.insert(item.key());
  return keys;
}

std::set<std::string> strings_of(const nlohmann::json& array) {
  std::set<std::string> strings;
  for (const auto& item : array) strings.insert(item.get<std::string>());
  return strings;
}

/// Every "$ref" string anywhere under `node`.
void collect_refs(const nlohmann::json& node, std::set<std::string>& refs) {
  if (node.is_object()) {
    for (const auto& item : node.items()) {
      if (item.key() == "$ref") refs.insert(item.value().get<std::string>());
      collect_refs(item.value(), refs);
    }
  } else if (node.is_array()) {
    for (const auto& item : node) collect_refs(item, refs);
  }
}

TEST(OpenApi, IsValidJsonOfVersion303) {
  ASSERT_TRUE(nlohmann::json::accept(openapi_document()));
  const nlohmann::json doc = document();
  EXPECT_EQ(doc.at("openapi"), "3.0.3");
  EXPECT_EQ(doc.at("info").at("title"), "tracemesh");
}

TEST(OpenApi, ListsEveryPathWithItsMethods) {
  const nlohmann::json paths = document().at("paths");
  EXPECT_EQ(keys_of(paths), (std::set<std::string>{"/mesh", "/jobs", "/jobs/{id}", "/jobs/{id}/mesh", "/healthz",
                                                    "/readyz", "/metrics", "/openapi.json"}));
  EXPECT_TRUE(paths.at("/mesh").contains("post"));
  EXPECT_TRUE(paths.at("/jobs").contains("post"));
  EXPECT_TRUE(paths.at("/jobs/{id}").contains("get"));
  EXPECT_TRUE(paths.at("/jobs/{id}").contains("delete"));
  EXPECT_TRUE(paths.at("/jobs/{id}/mesh").contains("get"));
  for (const char* path : {"/healthz", "/readyz", "/metrics", "/openapi.json"}) {
    EXPECT_TRUE(paths.at(path).contains("get")) << path;
  }
}

TEST(OpenApi, MeshResponsesCarryTheDocumentedHeadersAndErrors) {
  const nlohmann::json post = document().at("paths").at("/mesh").at("post");
  const nlohmann::json ok = post.at("responses").at("200");
  EXPECT_EQ(keys_of(ok.at("headers")), (std::set<std::string>{"ETag", "X-Cache", "X-Job-Id", "Content-Disposition"}));
  EXPECT_EQ(keys_of(ok.at("content")),
            (std::set<std::string>{std::string(content_type(mesh_format::off)),
                                   std::string(content_type(mesh_format::draco))}));
  for (const char* code : {"400", "405", "413", "415", "422", "429", "503"}) {
    EXPECT_TRUE(post.at("responses").contains(code)) << code;
  }
  EXPECT_TRUE(document().at("paths").at("/jobs").at("post").at("responses").contains("202"));
}

TEST(OpenApi, EveryReferenceResolves) {
  const nlohmann::json doc = document();
  std::set<std::string> refs;
  collect_refs(doc, refs);
  EXPECT_GT(refs.size(), 10U);
  for (const std::string& ref : refs) {
    ASSERT_EQ(ref.rfind("#/", 0), 0U) << ref;
    EXPECT_TRUE(doc.contains(nlohmann::json::json_pointer(ref.substr(1)))) << ref;
  }
}

TEST(OpenApi, ParameterRangesMatchTheEngine) {
  const nlohmann::json doc = document();
  const nlohmann::json& density = schema(doc, "Density");
  EXPECT_EQ(density.at("minimum"), parameter_ranges::min_density);
  EXPECT_EQ(density.at("maximum"), parameter_ranges::max_density);
  EXPECT_EQ(density.at("default"), mesh_params{}.density);
  const nlohmann::json& d = schema(doc, "DecayRate");
  EXPECT_EQ(d.at("minimum"), parameter_ranges::min_d);
  EXPECT_EQ(d.at("maximum"), parameter_ranges::max_d);
  EXPECT_EQ(d.at("default"), mesh_params{}.d);
  const nlohmann::json& t0 = schema(doc, "Isovalue");
  EXPECT_EQ(t0.at("minimum"), parameter_ranges::min_t0);
  EXPECT_EQ(t0.at("maximum"), parameter_ranges::max_t0);
  EXPECT_EQ(t0.at("default"), mesh_params{}.t0);
}

TEST(OpenApi, EnumerationsMatchTheCode) {
  const nlohmann::json doc = document();
  std::set<std::string> formats;
  for (const mesh_format format : {mesh_format::off, mesh_format::draco}) formats.insert(std::string(format_name(format)));
  EXPECT_EQ(strings_of(schema(doc, "MeshFormat").at("enum")), formats);
  EXPECT_EQ(schema(doc, "MeshFormat").at("default"), format_name(mesh_request{}.format));

  std::set<std::string> states;
  for (const job_state state :
       {job_state::queued, job_state::running, job_state::done, job_state::failed, job_state::cancelled}) {
    states.insert(std::string(job_state_name(state)));
  }
  EXPECT_EQ(strings_of(schema(doc, "JobStatus").at("enum")), states);

  std::set<std::string> stages;
  for (int s = 0; s <= static_cast<int>(mesh_stage::done); ++s) stages.insert(stage_name(static_cast<mesh_stage>(s)));
  EXPECT_EQ(strings_of(schema(doc, "Stage").at("enum")), stages);
}

TEST(OpenApi, ReportSchemaMatchesReportToJson) {
  const nlohmann::json doc = document();
  mesh_output output;
  output.report.components.resize(1);
  const nlohmann::json report = report_to_json(output, mesh_params{});
  EXPECT_EQ(strings_of(schema(doc, "MeshReport").at("required")), keys_of(report));
  EXPECT_EQ(keys_of(schema(doc, "MeshReport").at("properties")), keys_of(report));
  EXPECT_EQ(strings_of(schema(doc, "Certificate").at("required")), keys_of(report.at("certificate")));
  EXPECT_EQ(strings_of(schema(doc, "Quality").at("required")), keys_of(report.at("quality")));
  EXPECT_EQ(strings_of(schema(doc, "Component").at("required")), keys_of(report.at("components").at(0)));
  EXPECT_EQ(strings_of(schema(doc, "MeshParameters").at("required")), keys_of(report.at("parameters")));
}

TEST(OpenApi, ErrorSchemaMatchesErrorBody) {
  const nlohmann::json doc = document();
  const nlohmann::json body = error_body("invalid_argument", "x");
  const nlohmann::json& error = schema(doc, "Error");
  EXPECT_EQ(strings_of(error.at("required")), keys_of(body));
  EXPECT_EQ(strings_of(error.at("properties").at("error").at("required")), keys_of(body.at("error")));
}

}  // namespace
}  // namespace tracemesh::proto
