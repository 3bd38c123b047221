// The quality pass's last stage projects every vertex an edit placed onto the surface
// (remesh_operations::settle_vertices); that projection may not fold a triangle the edits left unfolded.
#include <gtest/gtest.h>

#include "core/io/pqr_reader.hpp"
#include "core/mesher.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

// mache at d = −15, t0 = 0.1, 1 v/Å² is traced on its third line grid (the first two fail). There a split or collapse
// placed a vertex at its coarse projection tolerance, on a triangle accepted nearly edge-on to its corner normals,
// and the projection that settled it, hundredths of an Å away, turned the triangle against all three: the
// certificate refused the fold and the lattice path made the mesh. The settling now refuses a stage whose
// projections fold a triangle, so that round is redone with the region frozen and the trace path's mesh is
// certified.
TEST(remesh_operations, settling_the_vertices_of_a_sharp_kernel_mesh_folds_no_triangle) {
  const result<molecule> mol = read_pqr_file(testing::molecule_path("mache.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  mesh_params params;
  params.method = mesh_method::trace;
  params.density = 1;
  params.d = -15;
  params.t0 = 0.1;
  params.refine = refine_mode::full;
  progress_token progress;
  const result<mesh_output> out = mesh_molecule(*mol, params, {}, progress);
  ASSERT_TRUE(out.ok()) << out.error().message();
  EXPECT_TRUE(out->certified);
  EXPECT_TRUE(out->fallback_reason.empty()) << out->fallback_reason;
  EXPECT_EQ(method_used(out->method, *out), mesh_method::trace);
  EXPECT_EQ(out->report.folded_triangles, 0u);
}

}  // namespace
}  // namespace tracemesh
