#include "proto/openapi.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <regex>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "core/io/input_format.hpp"

#include "proto/api_types.hpp"
#include "proto/report_json.hpp"
#include "support/json_keys.hpp"

namespace tracemesh::proto {
namespace {

nlohmann::json document() { return nlohmann::json::parse(openapi_document()); }

const nlohmann::json& schema(const nlohmann::json& doc, const std::string& name) {
  return doc.at("components").at("schemas").at(name);
}

using testing::keys_of;

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
  EXPECT_EQ(keys_of(paths), (std::set<std::string>{"/mesh", "/jobs", "/jobs/{id}", "/jobs/{id}/mesh", "/jobs/{id}/events",
                                                    "/healthz", "/readyz", "/metrics", "/openapi.json", "/",
                                                    "/favicon.ico", "/assets/{build}/{file}"}));
  EXPECT_TRUE(paths.at("/jobs/{id}/events").contains("get"));
  EXPECT_TRUE(paths.at("/mesh").contains("post"));
  EXPECT_TRUE(paths.at("/jobs").contains("post"));
  EXPECT_TRUE(paths.at("/jobs/{id}").contains("get"));
  EXPECT_TRUE(paths.at("/jobs/{id}").contains("delete"));
  EXPECT_TRUE(paths.at("/jobs/{id}/mesh").contains("get"));
  for (const char* path : {"/healthz", "/readyz", "/metrics", "/openapi.json", "/", "/favicon.ico",
                           "/assets/{build}/{file}"}) {
    EXPECT_TRUE(paths.at(path).contains("get")) << path;
  }
}

TEST(OpenApi, MeshResponsesCarryTheDocumentedHeadersAndErrors) {
  const nlohmann::json post = document().at("paths").at("/mesh").at("post");
  const nlohmann::json ok = post.at("responses").at("200");
  EXPECT_EQ(keys_of(ok.at("headers")), (std::set<std::string>{"ETag", "X-Cache", "X-Job-Id", "Content-Disposition",
                                                              "Content-Encoding", "Vary"}));
  std::set<std::string> content_types;
  for (const mesh_format_info& row : mesh_formats()) content_types.insert(std::string(row.content_type));
  EXPECT_EQ(keys_of(ok.at("content")), content_types);
  for (const char* code : {"400", "405", "413", "415", "422", "429", "503"}) {
    EXPECT_TRUE(post.at("responses").contains(code)) << code;
  }
  EXPECT_TRUE(document().at("paths").at("/jobs").at("post").at("responses").contains("202"));
  EXPECT_TRUE(post.at("responses").contains("406"));
  // The wire of GET /jobs/{id}/mesh: codings, ranges (issue 11 item 6).
  const nlohmann::json get = document().at("paths").at("/jobs/{id}/mesh").at("get").at("responses");
  for (const char* code : {"200", "206", "304", "406", "416"}) EXPECT_TRUE(get.contains(code)) << code;
  for (const char* header : {"Content-Encoding", "Vary", "Accept-Ranges", "ETag"}) {
    EXPECT_TRUE(get.at("200").at("headers").contains(header)) << header;
  }
  EXPECT_TRUE(get.at("206").at("headers").contains("Content-Range"));
  EXPECT_TRUE(get.at("416").at("headers").contains("Content-Range"));
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

  const trace_parameters trace;
  const nlohmann::json& degree = schema(doc, "TraceDegree");
  EXPECT_EQ(degree.at("type"), "integer");
  EXPECT_EQ(degree.at("minimum"), parameter_ranges::min_legendre_degree);
  EXPECT_EQ(degree.at("maximum"), parameter_ranges::max_legendre_degree);
  EXPECT_EQ(degree.at("default"), trace.legendre_degree);
  const nlohmann::json& step = schema(doc, "TraceStepFraction");
  EXPECT_EQ(step.at("minimum"), parameter_ranges::min_trace_step_fraction);
  EXPECT_EQ(step.at("maximum"), parameter_ranges::max_trace_step_fraction);
  EXPECT_EQ(step.at("default"), trace.step_fraction);
  const nlohmann::json& cos_bound = schema(doc, "TraceCosBound");
  EXPECT_EQ(cos_bound.at("minimum"), parameter_ranges::min_trace_cos_bound);
  EXPECT_EQ(cos_bound.at("maximum"), parameter_ranges::max_trace_cos_bound);
  EXPECT_EQ(cos_bound.at("default"), trace.cos_bound);
  const nlohmann::json& tolerance = schema(doc, "TraceExtremeTolerance");
  EXPECT_EQ(tolerance.at("minimum"), parameter_ranges::min_extreme_tolerance);
  EXPECT_EQ(tolerance.at("maximum"), parameter_ranges::max_extreme_tolerance);
  EXPECT_EQ(tolerance.at("default"), trace.extreme_tolerance);
  EXPECT_EQ(mesh_params{}.trace.legendre_degree, trace.legendre_degree);
}

TEST(OpenApi, UploadRoutesDocumentEveryRequestField) {
  // Each field the service reads is a query parameter and a form field of POST /mesh and POST /jobs, and nothing
  // else is: the document and the parser list the same names.
  const nlohmann::json doc = document();
  std::set<std::string> fields(mesh_request_fields.begin(), mesh_request_fields.end());
  fields.insert(structure_option_names.begin(), structure_option_names.end());  // PDB/mmCIF input options
  for (const char* path : {"/mesh", "/jobs"}) {
    std::set<std::string> query;
    for (const nlohmann::json& parameter : doc.at("paths").at(path).at("post").at("parameters")) {
      const std::string ref = parameter.at("$ref");
      const nlohmann::json& resolved = doc.at(nlohmann::json::json_pointer(ref.substr(1)));
      EXPECT_EQ(resolved.at("in"), "query") << ref;
      query.insert(resolved.at("name").get<std::string>());
    }
    EXPECT_EQ(query, fields) << path;
  }
  std::set<std::string> form = keys_of(doc.at("components").at("requestBodies").at("MeshUpload").at("content").at(
      "multipart/form-data").at("schema").at("properties"));
  EXPECT_EQ(form.erase("pqr"), 1U);
  EXPECT_EQ(form.erase("structure"), 1U);
  EXPECT_EQ(form, fields);
}

TEST(OpenApi, EnumerationsMatchTheCode) {
  const nlohmann::json doc = document();
  std::set<std::string> formats;
  for (const mesh_format_info& row : mesh_formats()) formats.insert(std::string(row.name));
  EXPECT_EQ(strings_of(schema(doc, "MeshFormat").at("enum")), formats);
  EXPECT_EQ(schema(doc, "MeshFormat").at("default"), format_name(mesh_request{}.format));

  std::set<std::string> states;
  for (const job_state state :
       {job_state::queued, job_state::running, job_state::done, job_state::failed, job_state::cancelled}) {
    states.insert(std::string(job_state_name(state)));
  }
  EXPECT_EQ(strings_of(schema(doc, "JobStatus").at("enum")), states);

  const std::set<std::string> methods = {method_name(mesh_method::trace), method_name(mesh_method::lattice)};
  EXPECT_EQ(strings_of(schema(doc, "MeshMethod").at("enum")), methods);
  EXPECT_EQ(schema(doc, "MeshMethod").at("default"), method_name(mesh_params{}.method));
  const std::set<std::string> refines = {refine_name(refine_mode::none), refine_name(refine_mode::full)};
  EXPECT_EQ(strings_of(schema(doc, "RefineMode").at("enum")), refines);
  EXPECT_EQ(schema(doc, "RefineMode").at("default"), refine_name(mesh_params{}.refine));

  std::set<std::string> input_formats;
  for (const input_format format : {input_format::pqr, input_format::pdb, input_format::mmcif, input_format::xyzr}) {
    input_formats.insert(std::string(input_format_name(format)));
  }
  EXPECT_EQ(strings_of(schema(doc, "InputFormat").at("enum")), input_formats);
  const std::set<std::string> radii_sources = {"file", std::string(radii_set_name(radii_set::bondi)),
                                               std::string(radii_set_name(radii_set::mantina))};
  EXPECT_EQ(strings_of(schema(doc, "InputSummary").at("properties").at("radii").at("enum")), radii_sources);

  // The assembly id's pattern accepts what parse_structure_options accepts.
  const nlohmann::json& assembly = schema(doc, "AssemblyId");
  EXPECT_EQ(assembly.at("default"), deposited_assembly);
  EXPECT_EQ(assembly.at("pattern"), "^[A-Za-z0-9_.-]{1," + std::to_string(max_assembly_id_chars) + "}$");
  const std::regex pattern(assembly.at("pattern").get<std::string>());
  for (const std::string& id : {std::string("asu"), std::string("1"), std::string("PAU"), std::string("a_b-c.d"),
                                std::string(), std::string("1 2"), std::string("1,2"), std::string("(1)"),
                                std::string(32, '9'), std::string(33, '9')}) {
    const result<structure_options> parsed = parse_structure_options([&](std::string_view name) {
      return name == "assembly" ? std::optional<std::string>(id) : std::nullopt;
    });
    EXPECT_EQ(parsed.ok(), std::regex_match(id, pattern)) << "'" << id << "'";
  }

  std::set<std::string> stages;
  for (int s = 0; s <= static_cast<int>(mesh_stage::done); ++s) stages.insert(stage_name(static_cast<mesh_stage>(s)));
  EXPECT_EQ(strings_of(schema(doc, "Stage").at("enum")), stages);
  EXPECT_EQ(stages.count("tracing"), 1U);
}

TEST(OpenApi, ReportSchemaMatchesReportToJson) {
  const nlohmann::json doc = document();
  mesh_output output;
  output.report.components.resize(1);
  mesh_params lattice, trace;
  lattice.method = mesh_method::lattice;
  trace.method = mesh_method::trace;
  const nlohmann::json report = report_to_json(output, lattice);
  EXPECT_EQ(strings_of(schema(doc, "MeshReport").at("required")), keys_of(report));
  std::set<std::string> properties = keys_of(schema(doc, "MeshReport").at("properties"));
  EXPECT_EQ(properties.erase("encodings"), 1U) << "added by the CLI and the service after report_to_json";
  EXPECT_EQ(properties.erase("input"), 1U) << "present when the caller says what it read";
  EXPECT_EQ(properties, keys_of(report));
  const nlohmann::json with_input = report_to_json(output, lattice, input_summary{input_format::pdb, "mantina"});
  EXPECT_EQ(with_input.at("input"), nlohmann::json({{"format", "pdb"}, {"radii", "mantina"}}));
  EXPECT_EQ(strings_of(schema(doc, "InputSummary").at("required")), keys_of(with_input.at("input")));
  input_summary capsid{input_format::pdb, "bondi", assembly_summary{"1", 60, 85712, 88}};
  const nlohmann::json with_assembly = report_to_json(output, lattice, capsid).at("input");
  EXPECT_EQ(keys_of(schema(doc, "InputSummary").at("properties")), keys_of(with_assembly))
      << "assembly: present when one was built";
  EXPECT_EQ(strings_of(schema(doc, "AssemblySummary").at("required")), keys_of(with_assembly.at("assembly")));
  EXPECT_EQ(keys_of(schema(doc, "AssemblySummary").at("properties")), keys_of(with_assembly.at("assembly")));
  EXPECT_EQ(keys_of(report_to_json(output, trace)), keys_of(report)) << "trace is null or an object, never absent";
  const nlohmann::json trace_section = report_to_json(output, trace).at("trace");
  EXPECT_EQ(strings_of(schema(doc, "TraceReport").at("required")), keys_of(trace_section));
  EXPECT_EQ(keys_of(schema(doc, "TraceReport").at("properties")), keys_of(trace_section));
  EXPECT_EQ(strings_of(schema(doc, "TraceParameters").at("required")), keys_of(trace_section.at("parameters")));
  EXPECT_EQ(keys_of(schema(doc, "TraceParameters").at("properties")), keys_of(trace_section.at("parameters")));
  EXPECT_EQ(schema(doc, "MeshReport").at("properties").at("trace").at("oneOf").at(1).at("$ref"),
            "#/components/schemas/Null");
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

namespace tracemesh::proto {
namespace {

// Issue 11 item 9: a real validator (swagger-parser) and Ajv's strict mode (no `nullable` without `type`, every
// schema compiles) accept the document; the served copy is checked in tests/integration.
TEST(OpenApi, PassesSwaggerParserAndAjvStrictMode) {
  std::string command = TRACEMESH_NODE;
  command.append(" ").append(TRACEMESH_SOURCE_DIR).append("/tests/node/check_openapi.mjs lint ");
  command.append(TRACEMESH_SOURCE_DIR).append("/proto/openapi.json > /dev/null 2>&1");
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
}

}  // namespace
}  // namespace tracemesh::proto
