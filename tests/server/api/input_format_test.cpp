// The input format of an upload through the real service: the file field 'pqr' and format_in declare it, a
// damaged PQR file is refused naming its lines (never read as PDB with table radii), a contradicted declaration
// is a 400, and a parameter sent twice (query and form) must agree.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "server/service_fixture.hpp"
#include "support/structure_writers.hpp"

namespace tracemesh::server::test::input_format {

using fields = std::vector<std::pair<std::string, std::string>>;

/// A multipart upload with the file in the field `file_field` and the given text fields.
std::string upload_in(const std::string& file_field, const std::string& target, const std::string& file,
                      const fields& form = {}) {
  const std::string boundary = "----tracemesh-input-format";
  std::string body;
  for (const auto& [name, value] : form) {
    body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + name + "\"\r\n\r\n" + value + "\r\n";
  }
  body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + file_field +
          "\"; filename=\"molecule\"\r\nContent-Type: application/octet-stream\r\n\r\n" + file + "\r\n--" + boundary +
          "--\r\n";
  return "POST " + target + " HTTP/1.1\r\nHost: test\r\nContent-Type: multipart/form-data; boundary=" + boundary +
         "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}

/// `text` with the last field of its first line (a PQR record's radius) replaced by `radius` (empty: removed).
std::string with_first_radius(const std::string& text, const std::string& radius) {
  const std::size_t end = text.find('\n');
  const std::string line = text.substr(0, end);
  const std::size_t last = line.find_last_of(' ');
  const std::string damaged = radius.empty() ? line.substr(0, last) : line.substr(0, last + 1) + radius;
  return damaged + text.substr(end);
}

/// The x coordinate of the first vertex of an OFF mesh: the fake mesher puts it at the first atom's radius.
double first_vertex_x(const std::string& off) {
  std::istringstream in(off);
  std::string magic;
  std::size_t vertices = 0, faces = 0, edges = 0;
  double x = 0;
  in >> magic >> vertices >> faces >> edges >> x;
  return x;
}

class InputFormatTest : public service_fixture {
 protected:
  http_reply send(const std::string& field, const std::string& target, const std::string& file,
                  const fields& form = {}) {
    return round_trip(port_, upload_in(field, target, file, form));
  }
  std::string message_of(const http_reply& reply) {
    const nlohmann::json doc = nlohmann::json::parse(reply.body, nullptr, false);
    return doc.is_discarded() ? std::string() : doc["error"]["message"].get<std::string>();
  }
};

TEST_F(InputFormatTest, APqrWithAnUnreadableFirstRadiusIs400NamingTheLine) {
  start();
  ASSERT_TRUE(gly_.starts_with("ATOM")) << "the first line of gly.pqr is an atom record";
  for (const std::string damage : {"*****", "nan", "inf", "radius", ""}) {
    const std::string damaged = with_first_radius(gly_, damage);
    for (const char* field : {"pqr", "structure"}) {
      const http_reply reply = send(field, "/mesh", damaged);
      expect_error(reply, 400, "invalid_input");
      EXPECT_TRUE(message_of(reply).starts_with("line 1: ")) << field << ", '" << damage << "': " << reply.body;
    }
  }
  EXPECT_EQ(mesher_.runs(), 0) << "no damaged file reached the mesher";
}

TEST_F(InputFormatTest, ManyDamagedLinesAreCountedInOneError) {
  start();
  std::string damaged = with_first_radius(gly_, "*****");
  const std::size_t second = damaged.find('\n') + 1;
  damaged = damaged.substr(0, second) + with_first_radius(damaged.substr(second), "nan");
  const http_reply reply = send("pqr", "/mesh", damaged);
  expect_error(reply, 400, "invalid_input");
  EXPECT_TRUE(message_of(reply).ends_with("; 2 of 7 atom records cannot be read as PQR (lines 1, 2)")) << reply.body;
}

TEST_F(InputFormatTest, FormatInDecidesTheAmbiguousCase) {
  start();
  // A PDB record without element symbols ends with occupancy and B-factor: detected as PQR, whose radius is the
  // B-factor 7.73; declared PDB, the carbon gets Bondi's 1.70 Å.
  const std::string record = "ATOM      1  CA  GLY A   1      -8.901   4.127  -0.555  1.00  7.73\n";
  const http_reply detected = send("structure", "/mesh", record);
  ASSERT_EQ(detected.status, 200) << detected.body;
  EXPECT_DOUBLE_EQ(first_vertex_x(detected.body), 7.73);
  const http_reply declared = send("structure", "/mesh?format_in=pdb", record);
  ASSERT_EQ(declared.status, 200) << declared.body;
  EXPECT_DOUBLE_EQ(first_vertex_x(declared.body), 1.70);
  const http_reply as_form_field = send("structure", "/mesh", record, {{"format_in", "pdb"}});
  ASSERT_EQ(as_form_field.status, 200) << as_form_field.body;
  ASSERT_FALSE(declared.header("x-job-id").empty());  // header names are stored in lower case
  EXPECT_EQ(as_form_field.header("x-job-id"), declared.header("x-job-id"));
}

TEST_F(InputFormatTest, AContradictedDeclarationIs400) {
  start();
  const auto atoms = tracemesh::testing::atoms_of_pqr(gly_);
  const std::string cif = tracemesh::testing::to_mmcif(atoms);
  const std::string pdb = tracemesh::testing::to_pdb(atoms);
  expect_error(send("pqr", "/mesh", cif), 400, "invalid_input");
  expect_error(send("pqr", "/jobs", pdb), 400, "invalid_input");
  expect_error(send("structure", "/mesh?format_in=pqr", cif), 400, "invalid_input");
  expect_error(send("structure", "/mesh", gly_, {{"format_in", "mmcif"}}), 400, "invalid_input");
  const http_reply both = send("pqr", "/mesh?format_in=pdb", gly_);
  expect_error(both, 400, "invalid_argument");
  EXPECT_EQ(message_of(both),
            "the file field 'pqr' declares pqr, but format_in=pdb; send the file in the field 'structure'");
  expect_error(send("structure", "/mesh?format_in=cif", gly_), 400, "invalid_argument");
  EXPECT_EQ(mesher_.runs(), 0);
  // Declared as what they are, they read.
  EXPECT_EQ(send("pqr", "/mesh?format_in=pqr", gly_).status, 200);
  EXPECT_EQ(send("structure", "/mesh?format_in=mmcif", cif).status, 200);
  EXPECT_EQ(send("structure", "/mesh", pdb, {{"format_in", "pdb"}}).status, 200);
}

TEST_F(InputFormatTest, AQueryParameterAndAFormFieldMustAgree) {
  start();
  const http_reply different = send("pqr", "/mesh?density=2", gly_, {{"density", "3"}});
  expect_error(different, 400, "invalid_argument");
  EXPECT_EQ(message_of(different), "parameter 'density' given in the query ('2') and in the form ('3') with different "
                                   "values");
  expect_error(send("structure", "/jobs?format_in=pqr", gly_, {{"format_in", "pdb"}}), 400, "invalid_argument");
  EXPECT_EQ(mesher_.runs(), 0);
  EXPECT_EQ(send("pqr", "/mesh?density=2", gly_, {{"density", "2"}}).status, 200) << "the same value twice is fine";
}

}  // namespace tracemesh::server::test::input_format

namespace tracemesh::server::test::input_format {

// The job's report (and so its record) says what the submission read and where the radii came from.
TEST_F(InputFormatTest, TheJobReportSaysWhichFormatWasReadAndWhereTheRadiiCameFrom) {
  start();
  const auto job_report_input = [&](const std::string& field, const std::string& target, const std::string& file) {
    const http_reply accepted = send(field, target, file);
    EXPECT_EQ(accepted.status, 202) << accepted.body;
    const nlohmann::json doc = wait_job(nlohmann::json::parse(accepted.body).at("id").get<std::string>());
    EXPECT_EQ(doc.value("status", ""), "done") << doc;
    return doc.contains("report") ? doc.at("report").value("input", nlohmann::json()) : nlohmann::json();
  };
  EXPECT_EQ(job_report_input("pqr", "/jobs", gly_), (nlohmann::json{{"format", "pqr"}, {"radii", "file"}}));
  const std::string pdb = tracemesh::testing::to_pdb(tracemesh::testing::atoms_of_pqr(gly_));
  EXPECT_EQ(job_report_input("structure", "/jobs", pdb), (nlohmann::json{{"format", "pdb"}, {"radii", "bondi"}}));
  EXPECT_EQ(job_report_input("structure", "/jobs?radii=mantina", pdb),
            (nlohmann::json{{"format", "pdb"}, {"radii", "mantina"}}));
}

}  // namespace tracemesh::server::test::input_format
