// Tests of server/jobs/job_id.hpp: the job id is a function of the parsed atoms and parameters only
// (service-test-list item 32: same PQR, different params → different keys; spelling → same key), method and refine
// included, and the trace parameters for the trace method.
#include "server/jobs/job_id.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "core/io/pqr_reader.hpp"
#include "server/storage/content_hash.hpp"
#include "server/storage/result_cache.hpp"

namespace tracemesh::server {
namespace {

molecule parse(std::string_view text) {
  result<molecule> mol = parse_pqr(text);
  EXPECT_TRUE(mol.ok()) << mol.error().message();
  return mol.ok() ? *mol : molecule{};
}

constexpr std::string_view two_atoms =
    "ATOM      1  N   GLY     1       1.000   2.000   3.000  -0.30   1.55\n"
    "ATOM      2  CA  GLY     1       2.500   2.000   3.000   0.10   1.70\n";

TEST(JobId, IsAHexDigestAndStable) {
  const std::string id = compute_job_id(parse(two_atoms), mesh_params{});
  EXPECT_TRUE(is_valid_job_id(id));
  EXPECT_EQ(id, compute_job_id(parse(two_atoms), mesh_params{}));
}

TEST(JobId, IgnoresHowTheAtomsWereWritten) {
  const std::string reformatted =
      "REMARK a comment the mesher never sees\r\n"
      "ATOM 1 N GLY 1 1.0 2 3.000 -0.3 1.550\r\n"
      "ATOM\t2\tCA\tGLY\t1\t2.5\t2.0\t3.0\t0.1\t1.7\r\n"
      "END\r\n";
  EXPECT_EQ(compute_job_id(parse(two_atoms), mesh_params{}), compute_job_id(parse(reformatted), mesh_params{}));
}

TEST(JobId, ChangesWithEveryInputThatChangesTheMesh) {
  const molecule mol = parse(two_atoms);
  const std::string base = compute_job_id(mol, mesh_params{});
  mesh_params density;
  density.density = 2.0;
  mesh_params decay;
  decay.d = -2.0;
  mesh_params isovalue;
  isovalue.t0 = 0.5;
  EXPECT_NE(base, compute_job_id(mol, density));
  EXPECT_NE(base, compute_job_id(mol, decay));
  EXPECT_NE(base, compute_job_id(mol, isovalue));
  molecule moved = mol;
  moved.atoms[1].center.x += 1e-9;
  EXPECT_NE(base, compute_job_id(moved, mesh_params{}));
  molecule recharged = mol;
  recharged.atoms[0].charge = 0.0;
  EXPECT_EQ(base, compute_job_id(recharged, mesh_params{})) << "no output depends on charges: PDB = PQR";
  molecule reordered = mol;
  std::swap(reordered.atoms[0], reordered.atoms[1]);
  EXPECT_NE(base, compute_job_id(reordered, mesh_params{}));
}

TEST(JobId, ChangesWithMethodAndRefine) {
  const molecule mol = parse(two_atoms);
  std::set<std::string> ids;
  for (const mesh_method method : {mesh_method::trace, mesh_method::lattice}) {
    for (const refine_mode refine : {refine_mode::none, refine_mode::full}) {
      mesh_params params;
      params.method = method;
      params.refine = refine;
      ids.insert(compute_job_id(mol, params));
    }
  }
  EXPECT_EQ(ids.size(), 4u);
  EXPECT_EQ(ids.count(compute_job_id(mol, mesh_params{})), 1u) << "the defaults are one of the four";
}

TEST(JobId, TraceParametersCountForTheTraceMethodOnly) {
  const molecule mol = parse(two_atoms);
  for (const mesh_method method : {mesh_method::trace, mesh_method::lattice}) {
    mesh_params base;
    base.method = method;
    const std::string id = compute_job_id(mol, base);
    std::vector<mesh_params> changed(4, base);
    changed[0].trace.legendre_degree = 12;
    changed[1].trace.step_fraction = 0.25;
    changed[2].trace.cos_bound = std::nextafter(base.trace.cos_bound, 0.0);
    changed[3].trace.extreme_tolerance = 0.01;
    for (std::size_t i = 0; i < changed.size(); ++i) {
      if (method == mesh_method::trace) {
        EXPECT_NE(compute_job_id(mol, changed[i]), id) << "trace parameter " << i;
      } else {
        EXPECT_EQ(compute_job_id(mol, changed[i]), id) << "trace parameter " << i << " does not change a lattice mesh";
      }
    }
  }
}

TEST(JobId, IgnoresThreadCountAndTheSignOfZero) {
  molecule mol = parse(two_atoms);
  mesh_params threaded;
  threaded.threads = 7;
  EXPECT_EQ(compute_job_id(mol, mesh_params{}), compute_job_id(mol, threaded));
  mol.atoms[0].center.z = 0.0;
  molecule negative_zero = mol;
  negative_zero.atoms[0].center.z = -0.0;
  EXPECT_EQ(compute_job_id(mol, mesh_params{}), compute_job_id(negative_zero, mesh_params{}));
}

TEST(JobId, HashesLargeMoleculesInBlocks) {
  molecule big;
  for (int i = 0; i < 20000; ++i) big.atoms.push_back(atom{{i * 0.5, 1.0, 2.0}, 1.5, 0.1});
  const std::string id = compute_job_id(big, mesh_params{});
  big.atoms.back().radius = 1.6;
  EXPECT_NE(id, compute_job_id(big, mesh_params{}));
}

TEST(JobId, ArtifactKeysAreValidCacheKeys) {
  const std::string id = compute_job_id(parse(two_atoms), mesh_params{});
  EXPECT_EQ(mesh_key(id, proto::mesh_format::off), id + ".off");
  EXPECT_EQ(mesh_key(id, proto::mesh_format::draco), id + ".draco");
  EXPECT_EQ(mesh_key(id, proto::mesh_format::glb_raw), id + ".glb_raw");
  for (const proto::mesh_format_info& row : proto::mesh_formats()) {
    EXPECT_TRUE(is_valid_cache_key(mesh_key(id, row.format))) << row.name;
  }
}

}  // namespace
}  // namespace tracemesh::server
