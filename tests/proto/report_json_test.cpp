#include "proto/report_json.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "support/json_keys.hpp"

namespace tracemesh::proto {
namespace {

/// A two-component output (an outer surface and a cavity) with distinct numbers in every field.
mesh_output sample_output() {
  mesh_output output;
  output.atoms_meshed = 906;
  output.zero_radius_atoms = 3;
  output.max_surface_distance = 2.5e-7;
  output.field_cutoff_error = 1e-6;
  output.certified = true;
  mesh_report& r = output.report;
  r.vertices = 5000;
  r.triangles = 9996;
  r.area = 4321.5;
  r.volume = 12345.25;
  r.components = {{4900, 9796, 4300.0, 12400.0, 2, 0, false}, {100, 200, 21.5, -54.75, 2, 0, true, true}};
  r.cavities = 1;
  r.euler_characteristic = 4;
  r.genus = 0;
  r.boundary_edges = 1;
  r.non_manifold_edges = 2;
  r.non_manifold_vertices = 3;
  r.inconsistently_oriented_edges = 4;
  r.degenerate_triangles = 5;
  r.unreferenced_vertices = 6;
  r.self_intersections = 7;
  r.inward_oriented_components = 8;
  r.folded_triangles = 9;
  r.near_duplicate_vertex_pairs = 10;
  r.achieved_density = 1.157;
  r.quality.edge_ratio_mean = 0.71;
  r.quality.edge_ratio_min = 0.12;
  r.quality.edge_ratio_histogram = {0, 1, 2, 30, 400, 500, 600, 700, 800, 6963};
  r.quality.fraction_below_0_2 = 1e-4;
  r.quality.min_angle_deg = 7.5;
  r.quality.shortest_edge = 0.05;
  r.quality.median_edge = 0.9;
  r.quality.longest_edge = 2.1;
  output.timings = {{mesh_stage::culling, 0.25}, {mesh_stage::sampling, 1.5}, {mesh_stage::culling, 0.5}};
  return output;
}

mesh_params sample_params() {
  mesh_params params;
  params.method = mesh_method::lattice;
  params.refine = refine_mode::full;
  params.density = 2;
  params.d = -0.75;
  params.t0 = 1.25;
  params.threads = 4;
  return params;
}

using testing::keys_of;

TEST(ReportJson, HasExactlyTheDocumentedTopLevelFields) {
  const nlohmann::json json = report_to_json(sample_output(), sample_params());
  EXPECT_EQ(keys_of(json), (std::set<std::string>{"engine_version", "parameters", "method", "method_used",
                                                  "fallback", "refine", "cavity_mode",
                                                  "dropped_components", "trace",
                                                  "atoms_meshed", "zero_radius_atoms", "vertices", "triangles",
                                                  "area", "volume", "components", "cavities", "genus",
                                                  "euler_characteristic", "certificate", "quality",
                                                  "achieved_density", "timings"}));
}

/// What a trace run counted, distinct numbers in every field.
trace_stats sample_trace_stats() {
  trace_stats t;
  t.line_spacing = 0.75;
  t.step = 0.375;
  t.lines = 101;
  t.proven_lines = 61;
  t.polynomial_roots = 102;
  t.tangent_root_intervals = 3;
  t.arcs = 104;
  t.bracketed_roots = 5;
  t.polygons = 106;
  t.extreme_points = 7;
  t.retraced_arcs = 8;
  t.untangled_points = 18;
  t.fallback_loops = 9;
  t.welded_edges = 15;
  t.collapsed_raw_edges = 17;
  t.level_shifted_strips = 12;
  t.untouched_cavities = 13;
  t.untouched_cavities_left = 14;
  t.field_evaluations = 2500;
  t.raw_vertices = 100;
  t.raw_triangles = 196;
  t.line_offset = {0.5, 0.25};
  t.grid_retries = 2;
  return t;
}

mesh_params trace_params() {
  mesh_params params = sample_params();
  params.method = mesh_method::trace;
  params.refine = refine_mode::none;
  params.trace.legendre_degree = 12;
  params.trace.step_fraction = 0.5;
  params.trace.cos_bound = 0.95;
  params.trace.extreme_tolerance = 0.01;
  return params;
}

TEST(ReportJson, EchoesMethodAndRefine) {
  for (const mesh_method method : {mesh_method::trace, mesh_method::lattice}) {
    for (const refine_mode refine : {refine_mode::none, refine_mode::full}) {
      mesh_params params = sample_params();
      params.method = method;
      params.refine = refine;
      const nlohmann::json json = report_to_json(sample_output(), params);
      EXPECT_EQ(json.at("method"), method_name(method));
      EXPECT_EQ(json.at("refine"), refine_name(refine));
      EXPECT_EQ(json.at("trace").is_null(), method == mesh_method::lattice) << json.at("trace");
    }
  }
}

TEST(ReportJson, ATraceJobMeshedByTheLatticePathSaysSo) {
  mesh_output output = sample_output();
  output.method = mesh_method::trace;
  output.trace = sample_trace_stats();  // what the failed trace counted: not this mesh's
  mesh_params params = trace_params();
  params.method = mesh_method::trace;
  const nlohmann::json as_traced = report_to_json(output, params);
  EXPECT_EQ(as_traced.at("method_used"), "trace");
  EXPECT_TRUE(as_traced.at("fallback").is_null());
  EXPECT_FALSE(as_traced.at("trace").is_null());

  output.fallback_reason = "trace polygons could not be closed: 0 roots without an arc, 1 cells ...";
  const nlohmann::json fell_back = report_to_json(output, params);
  EXPECT_EQ(fell_back.at("method"), "trace");
  EXPECT_EQ(fell_back.at("method_used"), "lattice");
  EXPECT_EQ(fell_back.at("fallback"), output.fallback_reason);
  EXPECT_TRUE(fell_back.at("trace").is_null());
}

TEST(ReportJson, TraceSectionHasTheParametersAndEveryCounter) {
  mesh_output output = sample_output();
  output.method = mesh_method::trace;
  output.trace = sample_trace_stats();
  const nlohmann::json trace = report_to_json(output, trace_params()).at("trace");
  EXPECT_EQ(trace.at("parameters"), (nlohmann::json{{"legendre_degree", 12},
                                                    {"step_fraction", 0.5},
                                                    {"step", 0.375},
                                                    {"line_spacing", 0.75},
                                                    {"cos_bound", 0.95},
                                                    {"extreme_tolerance", 0.01}}));
  EXPECT_EQ(trace, (nlohmann::json{{"parameters", trace.at("parameters")},
                                   {"line_offset", {0.5, 0.25}},
                                   {"grid_retries", 2},
                                   {"lines", 101},
                                   {"proven_lines", 61},
                                   {"polynomial_roots", 102},
                                   {"tangent_root_intervals", 3},
                                   {"arcs", 104},
                                   {"bracketed_roots", 5},
                                   {"polygons", 106},
                                   {"extreme_points", 7},
                                   {"retraced_arcs", 8},
                                   {"untangled_points", 18},
                                   {"fallback_loops", 9},
                                   {"welded_edges", 15},
                                   {"collapsed_raw_edges", 17},
                                   {"level_shifted_strips", 12},
                                   {"untouched_cavities", 13},
                                   {"untouched_cavities_left", 14},
                                   {"field_evaluations", 2500},
                                   {"raw_vertices", 100},
                                   {"raw_triangles", 196},
                                   {"field_evaluations_per_vertex", 25.0}}));
  EXPECT_EQ(trace, trace_to_json(trace_params().trace, sample_trace_stats()));
}

TEST(ReportJson, FieldEvaluationsPerVertexIsZeroWithoutVertices) {
  trace_stats empty;
  empty.field_evaluations = 12;
  const nlohmann::json trace = trace_to_json(trace_parameters{}, empty);
  EXPECT_EQ(trace.at("field_evaluations_per_vertex"), 0.0);
  EXPECT_EQ(trace.at("raw_vertices"), 0);
  EXPECT_EQ(nlohmann::json::parse(trace.dump()), trace);
}

TEST(ReportJson, ALatticeReportIgnoresTraceStatsAndParameters) {
  mesh_output output = sample_output();
  output.trace = sample_trace_stats();
  mesh_params params = trace_params();
  params.method = mesh_method::lattice;
  const nlohmann::json json = report_to_json(output, params);
  EXPECT_TRUE(json.at("trace").is_null());
  mesh_params untuned = sample_params();
  untuned.method = mesh_method::lattice;
  untuned.refine = refine_mode::none;
  EXPECT_EQ(json, report_to_json(output, untuned));
}

TEST(ReportJson, CopiesEveryValue) {
  const mesh_output output = sample_output();
  const nlohmann::json json = report_to_json(output, sample_params());
  EXPECT_EQ(json["engine_version"], engine_version);
  EXPECT_EQ(json["parameters"], (nlohmann::json{{"density", 2.0}, {"d", -0.75}, {"t0", 1.25}}));
  EXPECT_EQ(json["method"], "lattice");
  EXPECT_EQ(json["refine"], "full");
  EXPECT_TRUE(json["trace"].is_null());
  EXPECT_EQ(json["atoms_meshed"], 906);
  EXPECT_EQ(json["zero_radius_atoms"], 3);
  EXPECT_EQ(json["vertices"], 5000);
  EXPECT_EQ(json["triangles"], 9996);
  EXPECT_EQ(json["area"], 4321.5);
  EXPECT_EQ(json["volume"], 12345.25);
  EXPECT_EQ(json["cavities"], 1);
  EXPECT_EQ(json["genus"], 0);
  EXPECT_EQ(json["euler_characteristic"], 4);
  EXPECT_EQ(json["achieved_density"], 1.157);

  ASSERT_EQ(json["components"].size(), 2U);
  const nlohmann::json& cavity = json["components"][1];
  EXPECT_EQ(cavity, (nlohmann::json{{"vertices", 100}, {"triangles", 200}, {"area", 21.5}, {"volume", -54.75},
                                    {"genus", 0}, {"euler_characteristic", 2}, {"cavity", true},
                                    {"enclosed", true}}));
  EXPECT_EQ(json["components"][0]["cavity"], false);
  EXPECT_EQ(json["components"][0]["enclosed"], false);
  EXPECT_EQ(json["cavity_mode"], "keep");
  EXPECT_EQ(json["dropped_components"], 0);
  EXPECT_EQ(json["components"][0]["euler_characteristic"], 2);

  const nlohmann::json& certificate = json["certificate"];
  EXPECT_EQ(certificate["certified"], true);
  EXPECT_EQ(certificate["boundary_edges"], 1);
  EXPECT_EQ(certificate["non_manifold_edges"], 2);
  EXPECT_EQ(certificate["non_manifold_vertices"], 3);
  EXPECT_EQ(certificate["inconsistently_oriented_edges"], 4);
  EXPECT_EQ(certificate["degenerate_triangles"], 5);
  EXPECT_EQ(certificate["unreferenced_vertices"], 6);
  EXPECT_EQ(certificate["self_intersections"], 7);
  EXPECT_EQ(certificate["inward_oriented_components"], 8);
  EXPECT_EQ(certificate["folded_triangles"], 9);
  EXPECT_EQ(certificate["near_duplicate_vertex_pairs"], 10);
  EXPECT_EQ(certificate["max_surface_distance"], 2.5e-7);
  EXPECT_EQ(certificate["field_cutoff_error"], 1e-6);

  const nlohmann::json& quality = json["quality"];
  EXPECT_EQ(quality["edge_ratio_mean"], 0.71);
  EXPECT_EQ(quality["edge_ratio_min"], 0.12);
  EXPECT_EQ(quality["edge_ratio_histogram"],
            (nlohmann::json{0, 1, 2, 30, 400, 500, 600, 700, 800, 6963}));
  EXPECT_EQ(quality["fraction_below_0_2"], 1e-4);
  EXPECT_EQ(quality["min_angle_deg"], 7.5);
  EXPECT_EQ(quality["shortest_edge"], 0.05);
  EXPECT_EQ(quality["median_edge"], 0.9);
  EXPECT_EQ(quality["longest_edge"], 2.1);
}

TEST(ReportJson, CertifiedComesFromTheOutputNotTheReport) {
  mesh_output output = sample_output();  // the report counts defects...
  output.certified = false;
  EXPECT_EQ(report_to_json(output, {})["certificate"]["certified"], false);
  output.certified = true;  // ...but the mesher's verdict is what is reported
  EXPECT_EQ(report_to_json(output, {})["certificate"]["certified"], true);
}

TEST(ReportJson, TimingsNameTheTracingStage) {
  mesh_output output = sample_output();
  output.timings = {{mesh_stage::culling, 0.5}, {mesh_stage::roots, 0.25}, {mesh_stage::tracing, 1.0},
                    {mesh_stage::triangulating, 0.25}, {mesh_stage::certifying, 0.5}};
  const nlohmann::json timings = report_to_json(output, trace_params())["timings"];
  EXPECT_EQ(keys_of(timings),
            (std::set<std::string>{"culling", "roots", "tracing", "triangulating", "certifying", "total"}));
  EXPECT_DOUBLE_EQ(timings["tracing"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(timings["total"].get<double>(), 2.5);
}

TEST(ReportJson, TimingsSumPerStageAndInTotal) {
  const nlohmann::json timings = report_to_json(sample_output(), sample_params())["timings"];
  EXPECT_EQ(keys_of(timings), (std::set<std::string>{"culling", "sampling", "total"}));
  EXPECT_DOUBLE_EQ(timings["culling"].get<double>(), 0.75);
  EXPECT_DOUBLE_EQ(timings["sampling"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(timings["total"].get<double>(), 2.25);
  EXPECT_EQ(timings_to_json({}), (nlohmann::json{{"total", 0.0}}));
}

TEST(ReportJson, FailedAttemptsAreTimedApartAndInTheTotal) {
  mesh_output output = sample_output();
  output.failed_attempt_seconds = 0.5;
  const nlohmann::json timings = report_to_json(output, sample_params())["timings"];
  EXPECT_EQ(keys_of(timings), (std::set<std::string>{"culling", "sampling", "failed_attempts", "total"}));
  EXPECT_DOUBLE_EQ(timings["failed_attempts"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(timings["total"].get<double>(), 2.75);
}

TEST(ReportJson, ThreadsAreNotPartOfTheReport) {
  mesh_params one = sample_params(), many = sample_params();
  one.threads = 1;
  many.threads = 64;
  mesh_output output = sample_output();
  EXPECT_EQ(report_to_json(output, one), report_to_json(output, many));
}

TEST(ReportJson, OnlyTimingsDifferBetweenRunsOfTheSameJob) {
  mesh_output first = sample_output(), second = sample_output();
  second.timings = {{mesh_stage::sampling, 9.0}};
  nlohmann::json a = report_to_json(first, sample_params()), b = report_to_json(second, sample_params());
  EXPECT_NE(a, b);
  a.erase("timings");
  b.erase("timings");
  EXPECT_EQ(a.dump(), b.dump());
}

TEST(ReportJson, NonFiniteNumbersBecomeNullAndSurviveADump) {
  mesh_output output = sample_output();
  output.max_surface_distance = INFINITY;
  output.report.quality.min_angle_deg = NAN;
  output.trace.step = NAN;
  const nlohmann::json json = report_to_json(output, trace_params());
  EXPECT_TRUE(json["certificate"]["max_surface_distance"].is_null());
  EXPECT_TRUE(json["quality"]["min_angle_deg"].is_null());
  EXPECT_TRUE(json["trace"]["parameters"]["step"].is_null());
  EXPECT_EQ(nlohmann::json::parse(json.dump()), json);
}

TEST(ReportJson, EmptyOutput) {
  const nlohmann::json json = report_to_json(mesh_output{}, mesh_params{});
  EXPECT_TRUE(json["components"].is_array());
  EXPECT_TRUE(json["components"].empty());
  EXPECT_EQ(json["certificate"]["certified"], false);
  EXPECT_EQ(json["quality"]["edge_ratio_histogram"].size(), 10U);
}

TEST(ReportJson, TheInputNamesTheAssemblyBuiltAndOnlyThen) {
  read_molecule_result read;
  read.mol.atoms.resize(120);
  read.format = input_format::mmcif;
  read.radii = "mantina";
  EXPECT_EQ(input_to_json(summarize_input(read)), nlohmann::json({{"format", "mmcif"}, {"radii", "mantina"}}))
      << "asu: the file's own atoms, no assembly section";
  read.assembly = "2";
  read.assembly_operators = 60;
  read.assembly_merged_atoms = 5;
  EXPECT_EQ(input_to_json(summarize_input(read)),
            nlohmann::json({{"format", "mmcif"},
                            {"radii", "mantina"},
                            {"assembly", {{"id", "2"}, {"operators", 60}, {"atoms", 120}, {"merged_atoms", 5}}}}));
  EXPECT_EQ(report_to_json(mesh_output{}, mesh_params{}, summarize_input(read))["input"]["assembly"]["atoms"], 120);
}

}  // namespace
}  // namespace tracemesh::proto
