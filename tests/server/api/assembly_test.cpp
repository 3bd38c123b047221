// The parameter assembly through the real service (issue 35, point 3): the deposited 2BUK entry uploaded as it
// is, its biological assembly 1 read as 60 copies (the job's atoms, so its id), an id the file does not list and
// an assembly asked of a PQR file refused with 400, an assembly beyond the atom limit with 413.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test::assembly {

using fields = std::vector<std::pair<std::string, std::string>>;

/// A multipart upload of `file` in the field `file_field`, with the given text fields.
std::string upload_of(const std::string& file_field, const std::string& target, const std::string& file,
                      const fields& form = {}) {
  const std::string boundary = "----tracemesh-assembly";
  std::string body;
  for (const auto& [name, value] : form) {
    body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + name + "\"\r\n\r\n" + value + "\r\n";
  }
  body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + file_field +
          "\"; filename=\"2buk.pdb.gz\"\r\nContent-Type: application/octet-stream\r\n\r\n" + file + "\r\n--" +
          boundary + "--\r\n";
  return "POST " + target + " HTTP/1.1\r\nHost: test\r\nContent-Type: multipart/form-data; boundary=" + boundary +
         "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}

class AssemblyTest : public service_fixture {
 protected:
  http_reply send(const std::string& target, const std::string& file, const fields& form = {},
                  const std::string& field = "structure") {
    return round_trip(port_, upload_of(field, target, file, form));
  }
  std::string message_of(const http_reply& reply) {
    const nlohmann::json doc = nlohmann::json::parse(reply.body, nullptr, false);
    return doc.is_discarded() ? std::string() : doc["error"]["message"].get<std::string>();
  }
  /// The finished job of a 202 reply.
  nlohmann::json finished_job(const http_reply& accepted) {
    EXPECT_EQ(accepted.status, 202) << accepted.body;
    if (accepted.status != 202) return nlohmann::json::object();
    return wait_job(nlohmann::json::parse(accepted.body).at("id").get<std::string>());
  }

  // The deposited entry, gzipped as the PDB serves it; Mantina's radii, which have one for its calcium ions.
  const std::string entry_ = read_file(tracemesh::testing::test_data_path("molecules/2buk.pdb.gz"));
};

TEST_F(AssemblyTest, AssemblyOneOf2bukIsItsSixtyCopies) {
  start();
  const nlohmann::json unit = finished_job(send("/jobs?radii=mantina", entry_));
  ASSERT_EQ(unit.value("status", ""), "done") << unit;
  EXPECT_EQ(unit.at("report").at("atoms_meshed"), 1430) << "asu: the file's own atoms";
  const nlohmann::json capsid = finished_job(send("/jobs?radii=mantina&assembly=1", entry_));
  ASSERT_EQ(capsid.value("status", ""), "done") << capsid;
  EXPECT_EQ(capsid.at("report").at("atoms_meshed"), 60 * 1430 - 88) << "the ions on symmetry axes merged";
  EXPECT_NE(capsid.at("id"), unit.at("id")) << "the job id hashes the atoms read";
  EXPECT_EQ(capsid.at("report").at("input").at("assembly"),
            nlohmann::json({{"id", "1"}, {"operators", 60}, {"atoms", 60 * 1430 - 88}, {"merged_atoms", 88}}));
  EXPECT_FALSE(unit.at("report").at("input").contains("assembly")) << "only a built assembly is reported";
  // The same request with the parameter in the form is the same job.
  const http_reply meshed = send("/mesh?radii=mantina", entry_, {{"assembly", "1"}});
  ASSERT_EQ(meshed.status, 200) << meshed.body;
  EXPECT_EQ(meshed.header("x-job-id"), capsid.at("id").get<std::string>());
}

TEST_F(AssemblyTest, AnUnknownIdOrAnAssemblyOfAPqrFileIs400) {
  start();
  const http_reply unknown = send("/mesh?radii=mantina&assembly=9", entry_);
  expect_error(unknown, 400, "invalid_input");
  EXPECT_EQ(message_of(unknown),
            "assembly '9' is not in the file: its assemblies are 1, or asu (the file's own coordinates)");
  const http_reply pqr = send("/jobs?assembly=1", gly_, {}, "pqr");
  expect_error(pqr, 400, "invalid_input");
  EXPECT_EQ(message_of(pqr).rfind("assembly '1': a PQR file has no symmetry operators", 0), 0U) << pqr.body;
  const http_reply malformed = send("/mesh", entry_, {{"assembly", "1 2"}});
  expect_error(malformed, 400, "invalid_argument");
  EXPECT_EQ(message_of(malformed).rfind("assembly must be asu or an assembly id", 0), 0U) << malformed.body;
  EXPECT_EQ(mesher_.runs(), 0) << "nothing refused reached the mesher";
  EXPECT_EQ(send("/mesh?radii=mantina&assembly=asu", entry_).status, 200) << "asu is the default, spelled out";
}

TEST_F(AssemblyTest, AnAssemblyBeyondTheAtomLimitIs413) {
  start([](server_config& config) { config.limits.mesh.max_atoms = 60 * 1430 - 1; });
  const http_reply over = send("/mesh?radii=mantina&assembly=1", entry_);
  expect_error(over, 413, "limit_exceeded");
  EXPECT_EQ(message_of(over), "assembly '1' has 85800 atoms (60 operators), more than 85799 (limits.max_atoms)");
  EXPECT_EQ(mesher_.runs(), 0);
  EXPECT_EQ(send("/mesh?radii=mantina", entry_).status, 200) << "the unit alone fits";
}

}  // namespace tracemesh::server::test::assembly
