// Tests of server/storage/job_store.hpp: what survives a restart, what a crash at each write leaves, retention.
#include "server/storage/job_store.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "core/io/pqr_reader.hpp"
#include "proto/api_types.hpp"
#include "server/jobs/job_id.hpp"
#include "support/test_paths.hpp"

namespace tracemesh::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class JobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tracemesh-job-store-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    result<molecule> read = read_pqr_file(tracemesh::testing::molecule_path("gly.pqr"));
    ASSERT_TRUE(read.ok());
    input_.mol = *read;
    input_.params.density = 2;
    input_.format = proto::mesh_format::draco;
    id_ = compute_job_id(input_.mol, input_.params);
  }
  void TearDown() override { fs::remove_all(dir_); }

  job_store_options options(std::chrono::milliseconds retention = std::chrono::hours(1)) const {
    return job_store_options{dir_, retention, 1u << 20};
  }
  stored_job record() const {
    stored_job r;
    r.id = id_;
    r.parameters = proto::canonical_parameters(input_.params);
    r.format = input_.format;
    r.owners = {"owner-a"};
    r.accepted_ms = unix_millis();
    return r;
  }
  static surface_mesh tetrahedron() {
    surface_mesh mesh;
    mesh.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    mesh.normals = mesh.positions;
    mesh.atom_index = {0, 1, 2, 3};
    mesh.triangles = {{{0, 1, 2}}, {{0, 3, 1}}, {{0, 2, 3}}, {{1, 3, 2}}};
    return mesh;
  }
  fs::path file(std::string_view extension) const { return dir_ / id_.substr(0, 2) / (id_ + std::string(extension)); }

  fs::path dir_;
  job_input input_;
  std::string id_;
};

TEST_F(JobStoreTest, MeshesAndMoleculesRoundTripAndDamagedBytesAreRefused) {
  const surface_mesh mesh = tetrahedron();
  const std::string bytes = serialize_mesh(mesh);
  const std::optional<surface_mesh> back = deserialize_mesh(bytes);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->positions, mesh.positions);
  EXPECT_EQ(back->triangles, mesh.triangles);
  EXPECT_EQ(back->atom_index, mesh.atom_index);
  EXPECT_FALSE(deserialize_mesh(bytes.substr(0, bytes.size() - 1)));
  std::string bad_index = bytes;
  bad_index[bad_index.size() - 4] = 9;  // a corner past the last vertex
  EXPECT_FALSE(deserialize_mesh(bad_index));
  const std::optional<molecule> mol = deserialize_molecule(serialize_molecule(input_.mol));
  ASSERT_TRUE(mol);
  EXPECT_EQ(compute_job_id(*mol, input_.params), id_);
  EXPECT_FALSE(deserialize_molecule("short"));
}

TEST_F(JobStoreTest, AnAcceptedJobIsHandedBackAfterARestartWithItsInputOwnersAndFormat) {
  {
    job_store store(options());
    ASSERT_TRUE(store.open().ok());
    ASSERT_TRUE(store.accept(record(), input_).ok());
    ASSERT_TRUE(store.add_owner(id_, "owner-b").ok());
  }  // the process dies here: nothing else is written
  job_store reopened(options());
  ASSERT_TRUE(reopened.open().ok());
  const std::vector<unfinished_job> unfinished = reopened.take_unfinished();
  ASSERT_EQ(unfinished.size(), 1u);
  EXPECT_EQ(unfinished[0].record.id, id_);
  EXPECT_EQ(unfinished[0].record.owners, (std::vector<std::string>{"owner-a", "owner-b"}));
  EXPECT_EQ(unfinished[0].input->format, proto::mesh_format::draco);
  EXPECT_EQ(compute_job_id(unfinished[0].input->mol, unfinished[0].input->params), id_);
  EXPECT_TRUE(reopened.take_unfinished().empty()) << "handed out once";
}

TEST_F(JobStoreTest, ACompletedJobKeepsItsMeshAndReportAndDropsItsInput) {
  {
    job_store store(options());
    ASSERT_TRUE(store.open().ok());
    ASSERT_TRUE(store.accept(record(), input_).ok());
    ASSERT_TRUE(store.complete(id_, record(), tetrahedron(), std::make_shared<const std::string>("{\"r\":1}")).ok());
    EXPECT_FALSE(fs::exists(file(".input")));
  }
  job_store reopened(options());
  ASSERT_TRUE(reopened.open().ok());
  EXPECT_TRUE(reopened.take_unfinished().empty());
  const std::optional<stored_job> found = reopened.find(id_);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->state, job_state::done);
  EXPECT_EQ(*found->report, "{\"r\":1}");
  const auto mesh = reopened.mesh(id_);
  ASSERT_TRUE(mesh);
  EXPECT_EQ(mesh->triangles, tetrahedron().triangles);
}

TEST_F(JobStoreTest, AReportAmendedAfterTheJobEndedIsKeptAcrossARestart) {
  {
    job_store store(options());
    ASSERT_TRUE(store.open().ok());
    const auto append = [](const std::string& report) { return report + "+off"; };
    EXPECT_EQ(store.amend_report(id_, append).code(), errc::invalid_argument) << "no done job to amend";
    ASSERT_TRUE(store.accept(record(), input_).ok());
    EXPECT_EQ(store.amend_report(id_, append).code(), errc::invalid_argument) << "queued: no report yet";
    ASSERT_TRUE(store.complete(id_, record(), tetrahedron(), std::make_shared<const std::string>("report")).ok());
    ASSERT_TRUE(store.amend_report(id_, append).ok());
    ASSERT_TRUE(store.amend_report(id_, [](const std::string& report) { return report + "+ply"; }).ok());
    EXPECT_EQ(*store.find(id_)->report, "report+off+ply");
  }
  job_store reopened(options());
  ASSERT_TRUE(reopened.open().ok());
  const std::optional<stored_job> found = reopened.find(id_);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->state, job_state::done);
  EXPECT_EQ(*found->report, "report+off+ply");
  EXPECT_TRUE(reopened.mesh(id_));
}

TEST_F(JobStoreTest, ADamagedInputOrResultIsNeverUsedAndTheJobIsReportedLost) {
  {
    job_store store(options());
    ASSERT_TRUE(store.open().ok());
    ASSERT_TRUE(store.accept(record(), input_).ok());
  }
  std::fstream(file(".input"), std::ios::in | std::ios::out | std::ios::binary).seekp(60).put('\x7f');
  job_store reopened(options());
  ASSERT_TRUE(reopened.open().ok());
  EXPECT_TRUE(reopened.take_unfinished().empty());
  EXPECT_EQ(reopened.take_lost(), std::vector<std::string>{id_});
  const std::optional<stored_job> found = reopened.find(id_);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->state, job_state::failed);
  EXPECT_EQ(found->error_code, lost_job_error);

  ASSERT_TRUE(reopened.complete(id_, record(), tetrahedron(), std::make_shared<const std::string>("{}")).ok());
  std::fstream(file(".result"), std::ios::in | std::ios::out | std::ios::binary).seekp(70).put('\x7f');
  EXPECT_EQ(reopened.mesh(id_), nullptr) << "a result whose checksum fails is not served";
}

TEST_F(JobStoreTest, FinishedJobsAreForgottenAfterTheRetentionPeriod) {
  job_store store(options(50ms));
  ASSERT_TRUE(store.open().ok());
  ASSERT_TRUE(store.accept(record(), input_).ok());
  ASSERT_TRUE(store.complete(id_, record(), tetrahedron(), std::make_shared<const std::string>("{}")).ok());
  // Stored (a find() now could already be past the retention on a paused machine: the files say it was kept)...
  EXPECT_TRUE(fs::exists(file(".record")));
  EXPECT_TRUE(fs::exists(file(".result")));
  // ...and forgotten once the retention has certainly passed.
  std::this_thread::sleep_for(120ms);
  EXPECT_FALSE(store.find(id_));
  EXPECT_FALSE(fs::exists(file(".record")));
  EXPECT_FALSE(fs::exists(file(".result")));
}

TEST_F(JobStoreTest, AFileWhereTheDirectoryShouldBeIsAnError) {
  fs::create_directories(dir_.parent_path());
  std::ofstream(dir_) << "a file";
  job_store store(options());
  const status opened = store.open();
  EXPECT_EQ(opened.code(), errc::io_error);
  EXPECT_NE(opened.message().find("not a directory"), std::string::npos) << opened.message();
  fs::remove(dir_);
}

TEST_F(JobStoreTest, TheMemoryStoreForgetsTheOldestFinishedJobsPastItsBound) {
  job_store store(job_store_options{{}, std::chrono::hours(1), 3000});
  ASSERT_TRUE(store.open().ok());
  EXPECT_FALSE(store.durable());
  ASSERT_TRUE(store.complete(id_, record(), tetrahedron(), std::make_shared<const std::string>("{}")).ok());
  EXPECT_TRUE(store.mesh(id_));
  surface_mesh big = tetrahedron();
  big.positions.resize(110, vec3{});
  const std::string other(64, 'b');
  stored_job other_record = record();
  other_record.id = other;
  ASSERT_TRUE(store.complete(other, other_record, big, std::make_shared<const std::string>("{}")).ok());
  EXPECT_FALSE(store.find(id_)) << "the oldest went first";
  EXPECT_TRUE(store.mesh(other));
}

}  // namespace
}  // namespace tracemesh::server
