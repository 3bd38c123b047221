// Acceptance of the trace path (mesh_method::trace) on the small end of the shared molecule ladder — gly, adp,
// villin, fas2 and mache at densities 1 and 2 — raw (refine none) and refined (refine full): every mesh carries the
// certificate, meets the quality targets, reaches the requested density, encloses the same surface as the lattice
// path and reports consistent trace statistics.
//
// Reference for area and volume: the lattice path's mesh at the same density with its default refinement (its raw
// marching-tetrahedra mesh has about four times the requested density, so it is not a mesh "at that density").
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <string>

#include "core/io/pqr_reader.hpp"
#include "core/mesher.hpp"
#include "support/mesh_expectations.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

using testing::case_name;
using trace_case = testing::ladder_case;

result<mesh_output> mesh_with(const molecule& mol, double density, mesh_method method, refine_mode refine,
                              double& seconds) {
  mesh_params params;
  params.density = density;
  params.method = method;
  params.refine = refine;
  progress_token progress;
  const auto start = std::chrono::steady_clock::now();
  auto out = mesh_molecule(mol, params, {}, progress);
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

void expect_certified(const mesh_output& out) {
  testing::expect_certified_output(out);
  EXPECT_GT(out.report.volume, 0);
}

double relative(double value, double reference) { return (value - reference) / reference; }

void print_row(const trace_case& c, const char* refine, const mesh_output& out, const mesh_output& lattice,
               double seconds) {
  const mesh_report& r = out.report;
  std::printf(
      "[ trace    ] %-16s d=%.0f %-4s %6.2fs V=%-6zu density %.3f edge ratio %.3f (<0.2: %.4f%%) area %+.3f%% "
      "volume %+.3f%% vs lattice, components %zu (lattice %zu), cavities %zu, genus %ld | lines %zu roots "
      "%zu+%zu (tangent intervals %zu) arcs %zu polygons %zu fallbacks %zu retraced %zu evaluations %zu | folds %zu near duplicates %zu\n",
      c.file.c_str(), c.density, refine, seconds, r.vertices, r.achieved_density, r.quality.edge_ratio_mean,
      100 * r.quality.fraction_below_0_2, 100 * relative(r.area, lattice.report.area),
      100 * relative(r.volume, lattice.report.volume), r.components.size(), lattice.report.components.size(),
      r.cavities, r.genus, out.trace.lines, out.trace.polynomial_roots, out.trace.bracketed_roots,
      out.trace.tangent_root_intervals, out.trace.arcs, out.trace.polygons, out.trace.fallback_loops, out.trace.retraced_arcs,
      out.trace.field_evaluations, r.folded_triangles, r.near_duplicate_vertex_pairs);
}

class trace_ladder : public ::testing::TestWithParam<trace_case> {};

TEST_P(trace_ladder, raw_and_refined_meshes_are_certified_and_match_the_lattice_path) {
  const trace_case& c = GetParam();
  auto mol = read_pqr_file(testing::molecule_path(c.file));
  ASSERT_TRUE(mol.ok()) << mol.error().message();

  double lattice_seconds = 0, raw_seconds = 0, refined_seconds = 0;
  const auto lattice = mesh_with(*mol, c.density, mesh_method::lattice, refine_mode::full, lattice_seconds);
  ASSERT_TRUE(lattice.ok()) << "lattice reference: " << lattice.error().message();
  const auto raw = mesh_with(*mol, c.density, mesh_method::trace, refine_mode::none, raw_seconds);
  ASSERT_TRUE(raw.ok()) << "trace, refine none: " << raw.error().message();
  const auto refined = mesh_with(*mol, c.density, mesh_method::trace, refine_mode::full, refined_seconds);
  ASSERT_TRUE(refined.ok()) << "trace, refine full: " << refined.error().message();
  print_row(c, "raw", *raw, *lattice, raw_seconds);
  print_row(c, "full", *refined, *lattice, refined_seconds);

  const double area = lattice->report.area, volume = lattice->report.volume;
  {
    SCOPED_TRACE("refine none");
    const mesh_report& r = raw->report;
    expect_certified(*raw);
    EXPECT_EQ(r.folded_triangles, 0u);  // issue 34: a boundary-element solver stalls on folds
    EXPECT_EQ(raw->method, mesh_method::trace);
    EXPECT_EQ(raw->refine, refine_mode::none);
    // Issue 10's target, 0.70, once the short edges are collapsed for delivery (docs/method.md: without them
    // 0.688–0.698 on villin_1vii, fas2 and mache); gly's 246 triangles, mostly where its atoms meet, reach 0.687.
    EXPECT_GE(r.quality.edge_ratio_mean, r.triangles >= 1000 ? 0.70 : 0.68);
    // Issue 10's target for the raw mesh is under 1%; on the smallest meshes a few triangles are a large share (gly
    // at density 1: 2 of its 268, where two arcs dip to 0.03 h̃ of one line at the same x), hence "or 3 triangles".
    const double below = r.quality.fraction_below_0_2 * static_cast<double>(r.triangles);
    EXPECT_LE(below, std::max(0.01 * static_cast<double>(r.triangles), 3.0));
    EXPECT_NEAR(r.achieved_density, c.density, 0.2 * c.density);
    // The reference is itself off: on mache at density 1 the converged area (lattice, density 8) is 20,257 Å²; the
    // raw trace mesh has 20,177 (−0.4%) and the refined lattice reference 19,878 (−1.9%). Hence 2.5% here.
    EXPECT_NEAR(r.area, area, 0.025 * area);
    EXPECT_NEAR(r.volume, volume, 0.015 * volume);
    const trace_stats& t = raw->trace;
    EXPECT_EQ(t.raw_vertices, r.vertices + t.collapsed_raw_edges);  // the polygons, less the edges collapsed
    EXPECT_EQ(t.raw_triangles, r.triangles + 2 * t.collapsed_raw_edges);
    EXPECT_EQ(t.arcs, 2 * (t.polynomial_roots + t.bracketed_roots));  // one arc per root and strip
    EXPECT_GT(t.lines, 0u);
    EXPECT_GT(t.polygons, 0u);
    EXPECT_GT(t.field_evaluations, 0u);
    EXPECT_LE(t.fallback_loops, t.polygons / 100 + 5);  // a handful of fallbacks (docs/method.md#the-admissibility-rule: ~0.25%)
  }
  {
    SCOPED_TRACE("refine full");
    const mesh_report& r = refined->report;
    expect_certified(*refined);
    EXPECT_EQ(r.folded_triangles, 0u);
    EXPECT_EQ(refined->refine, refine_mode::full);
    EXPECT_GE(r.quality.edge_ratio_mean, 0.80);
    EXPECT_LT(r.quality.fraction_below_0_2, 0.005);
    // Issue 10's target (0.24 × at least on these molecules; mache at 2 v/Å² had 0.075 before arcs kept their
    // points clear of the lines, strip_arcs.cpp).
    EXPECT_GE(r.quality.shortest_edge, 0.1 * r.quality.median_edge);
    EXPECT_NEAR(r.achieved_density, c.density, 0.2 * c.density);
    EXPECT_NEAR(r.area, area, 0.015 * area);
    EXPECT_NEAR(r.volume, volume, 0.015 * volume);
    // The quality pass starts from the very mesh of refine none: the same trace, the same statistics.
    const trace_stats& t = refined->trace;
    EXPECT_EQ(t.raw_vertices, raw->trace.raw_vertices);
    EXPECT_EQ(t.raw_triangles, raw->trace.raw_triangles);
    EXPECT_EQ(t.arcs, raw->trace.arcs);
    EXPECT_EQ(t.polygons, raw->trace.polygons);
    EXPECT_EQ(t.field_evaluations, raw->trace.field_evaluations);
  }
}

INSTANTIATE_TEST_SUITE_P(ladder, trace_ladder,
                         ::testing::Values(trace_case{"gly.pqr", 1}, trace_case{"gly.pqr", 2}, trace_case{"adp.pqr", 1},
                                           trace_case{"adp.pqr", 2}, trace_case{"villin_1vii.pqr", 1},
                                           trace_case{"villin_1vii.pqr", 2}, trace_case{"fas2.pqr", 1},
                                           trace_case{"fas2.pqr", 2}, trace_case{"mache.pqr", 1},
                                           trace_case{"mache.pqr", 2}),
                         case_name);

}  // namespace
}  // namespace tracemesh
