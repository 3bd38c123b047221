#include "proto/report_json.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

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
  r.components = {{4900, 9796, 4300.0, 12400.0, 2, 0, false}, {100, 200, 21.5, -54.75, 2, 0, true}};
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
  params.density = 2;
  params.d = -0.75;
  params.t0 = 1.25;
  params.threads = 4;
  return params;
}

std::set<std::string> keys_of(const nlohmann::json& object) {
  std::set<std::string> keys;
  for (const auto& item : object.items()) keys.insert(item.key());
  return keys;
}

TEST(ReportJson, HasExactlyTheDocumentedTopLevelFields) {
  const nlohmann::json json = report_to_json(sample_output(), sample_params());
  EXPECT_EQ(keys_of(json), (std::set<std::string>{"engine_version", "parameters", "atoms_meshed",
                                                  "zero_radius_atoms", "vertices", "triangles", "area", "volume",
                                                  "components", "cavities", "genus", "euler_characteristic",
                                                  "certificate", "quality", "achieved_density", "timings"}));
}

TEST(ReportJson, CopiesEveryValue) {
  const mesh_output output = sample_output();
  const nlohmann::json json = report_to_json(output, sample_params());
  EXPECT_EQ(json["engine_version"], engine_version);
  EXPECT_EQ(json["parameters"], (nlohmann::json{{"density", 2.0}, {"d", -0.75}, {"t0", 1.25}}));
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
                                    {"genus", 0}, {"euler_characteristic", 2}, {"cavity", true}}));
  EXPECT_EQ(json["components"][0]["cavity"], false);
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

TEST(ReportJson, TimingsSumPerStageAndInTotal) {
  const nlohmann::json timings = report_to_json(sample_output(), sample_params())["timings"];
  EXPECT_EQ(keys_of(timings), (std::set<std::string>{"culling", "sampling", "total"}));
  EXPECT_DOUBLE_EQ(timings["culling"].get<double>(), 0.75);
  EXPECT_DOUBLE_EQ(timings["sampling"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(timings["total"].get<double>(), 2.25);
  EXPECT_EQ(timings_to_json({}), (nlohmann::json{{"total", 0.0}}));
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
  const nlohmann::json json = report_to_json(output, sample_params());
  EXPECT_TRUE(json["certificate"]["max_surface_distance"].is_null());
  EXPECT_TRUE(json["quality"]["min_angle_deg"].is_null());
  EXPECT_EQ(nlohmann::json::parse(json.dump()), json);
}

TEST(ReportJson, EmptyOutput) {
  const nlohmann::json json = report_to_json(mesh_output{}, mesh_params{});
  EXPECT_TRUE(json["components"].is_array());
  EXPECT_TRUE(json["components"].empty());
  EXPECT_EQ(json["certificate"]["certified"], false);
  EXPECT_EQ(json["quality"]["edge_ratio_histogram"].size(), 10U);
}

}  // namespace
}  // namespace tracemesh::proto
