#pragma once
// Shared expectations on meshing results: every part of the certificate checked one by one (so that a failure says
// which), and the molecule-and-density case of the ladder tests.
#include <gtest/gtest.h>

#include <ostream>
#include <string>

#include "core/mesher.hpp"

namespace tracemesh::testing {

/// Each topological and geometric condition of the certificate in an analysis (analyze_mesh with its default
/// options), one by one.
inline void expect_certified_report(const mesh_report& r) {
  EXPECT_TRUE(r.topologically_certified());
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_EQ(r.non_manifold_vertices, 0u);
  EXPECT_EQ(r.inconsistently_oriented_edges, 0u);
  EXPECT_EQ(r.degenerate_triangles, 0u);
  EXPECT_EQ(r.self_intersections, 0u);
  EXPECT_EQ(r.inward_oriented_components, 0u);
  EXPECT_EQ(r.unreferenced_vertices, 0u);
}

/// Each condition of the certificate, the field normals and atom indices of every vertex; and the requested path
/// made the mesh (no fallback from trace to lattice).
inline void expect_certified_output(const mesh_output& out) {
  EXPECT_TRUE(out.fallback_reason.empty()) << out.fallback_reason;
  EXPECT_TRUE(out.certified);
  expect_certified_report(out.report);
  EXPECT_LE(out.max_surface_distance, 1e-3);
  EXPECT_EQ(out.mesh.normals.size(), out.mesh.positions.size());
  EXPECT_EQ(out.mesh.atom_index.size(), out.mesh.positions.size());
}

/// One molecule of tests/data/molecules at one density.
struct ladder_case {
  std::string file;
  double density;
};

inline void PrintTo(const ladder_case& c, std::ostream* os) { *os << c.file << " at density " << c.density; }

/// "fas2_density_2" for fas2.pqr at density 2.
inline std::string case_name(const ::testing::TestParamInfo<ladder_case>& info) {
  std::string name = info.param.file.substr(0, info.param.file.find('.'));
  return name + "_density_" + std::to_string(static_cast<int>(info.param.density));
}

}  // namespace tracemesh::testing
