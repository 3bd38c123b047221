// The per-vertex component attribute of the Draco and PLY encodings indexes the report's components (largest area
// first), on a mesh with a cavity: every component row's vertex count is the number of vertices carrying its label,
// and with cavities=drop only label 0 (the outer surface) is left.
#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/mesher.hpp"
#include "proto/mesh_encoders.hpp"
#include "support/shell_molecule.hpp"

namespace tracemesh::proto {
namespace {

/// Vertices per component label.
std::map<std::int32_t, std::size_t> histogram(const std::vector<std::int32_t>& labels) {
  std::map<std::int32_t, std::size_t> counts;
  for (const std::int32_t label : labels) ++counts[label];
  return counts;
}

/// The `component` property of every vertex of a binary PLY written by encode_ply (x y z nx ny nz as float,
/// atom_index as uint, component as int: 32 bytes per vertex).
std::vector<std::int32_t> ply_components(const std::string& ply) {
  const std::string end = "end_header\n";
  const std::size_t body = ply.find(end) + end.size();
  const std::string count_key = "element vertex ";
  const std::size_t count_at = ply.find(count_key) + count_key.size();
  const std::size_t vertices = std::stoul(ply.substr(count_at, ply.find('\n', count_at) - count_at));
  std::vector<std::int32_t> labels(vertices);
  for (std::size_t v = 0; v < vertices; ++v) std::memcpy(&labels[v], ply.data() + body + v * 32 + 28, 4);
  return labels;
}

std::map<std::int32_t, std::size_t> report_rows(const mesh_report& report) {
  std::map<std::int32_t, std::size_t> rows;
  for (std::size_t c = 0; c < report.components.size(); ++c) {
    rows[static_cast<std::int32_t>(c)] = report.components[c].vertices;
  }
  return rows;
}

TEST(ComponentAttribute, DracoAndPlyLabelsMatchTheReportsComponentRows) {
  const molecule mol = testing::shell_with_island();
  for (const cavity_mode mode : {cavity_mode::keep, cavity_mode::drop}) {
    mesh_params params;
    params.cavities = mode;
    progress_token token;
    auto out = mesh_molecule(mol, params, mesh_limits{}, token);
    ASSERT_TRUE(out.ok()) << out.error().message();
    const std::map<std::int32_t, std::size_t> rows = report_rows(out->report);
    EXPECT_EQ(rows.size(), mode == cavity_mode::keep ? 3u : 1u);

    auto draco = encode_mesh(out->mesh, mesh_format::draco);
    ASSERT_TRUE(draco.ok()) << draco.error().message();
    std::vector<std::int32_t> labels;
    ASSERT_TRUE(decode_draco(*draco, &labels).ok());
    EXPECT_EQ(histogram(labels), rows) << cavity_mode_name(mode);

    auto ply = encode_mesh(out->mesh, mesh_format::ply);
    ASSERT_TRUE(ply.ok()) << ply.error().message();
    const std::vector<std::int32_t> ply_labels = ply_components(*ply);
    EXPECT_EQ(histogram(ply_labels), rows) << cavity_mode_name(mode);
    if (mode == cavity_mode::keep) {
      // The enclosed components' vertices carry the labels of the rows flagged enclosed.
      for (std::size_t v = 0; v < ply_labels.size(); ++v) {
        const component_report& row = out->report.components.at(static_cast<std::size_t>(ply_labels[v]));
        const bool inner = norm(out->mesh.positions[v]) < 8;  // the shell's centre radius; outer surface ≈ 9.8 Å
        ASSERT_EQ(row.enclosed, inner) << "vertex " << v;
      }
    }
  }
}

}  // namespace
}  // namespace tracemesh::proto
