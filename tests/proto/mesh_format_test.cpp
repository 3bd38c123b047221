#include "proto/mesh_format.hpp"

#include <gtest/gtest.h>

namespace tracemesh::proto {
namespace {

TEST(MeshFormat, ParsesTheApiSpellings) {
  ASSERT_TRUE(parse_mesh_format("off"));
  EXPECT_EQ(*parse_mesh_format("off"), mesh_format::off);
  ASSERT_TRUE(parse_mesh_format("draco"));
  EXPECT_EQ(*parse_mesh_format("draco"), mesh_format::draco);
}

TEST(MeshFormat, RejectsOtherSpellingsWithInvalidArgument) {
  for (const char* name : {"", "OFF", "Draco", "drc", ".off", "off ", " off", "obj", "draco\n"}) {
    const result<mesh_format> parsed = parse_mesh_format(name);
    ASSERT_FALSE(parsed) << name;
    EXPECT_EQ(parsed.error().code(), errc::invalid_argument);
    EXPECT_NE(parsed.error().message().find("format"), std::string::npos);
    EXPECT_EQ(parsed.error().message().find('\n'), std::string::npos) << "messages stay on one line";
  }
}

TEST(MeshFormat, NameIsTheInverseOfParse) {
  for (const mesh_format format : {mesh_format::off, mesh_format::draco}) {
    const result<mesh_format> parsed = parse_mesh_format(format_name(format));
    ASSERT_TRUE(parsed);
    EXPECT_EQ(*parsed, format);
  }
}

TEST(MeshFormat, ContentTypesAndExtensions) {
  EXPECT_EQ(content_type(mesh_format::off), "model/vnd.off");
  EXPECT_EQ(content_type(mesh_format::draco), "application/vnd.google.draco");
  EXPECT_EQ(file_extension(mesh_format::off), ".off");
  EXPECT_EQ(file_extension(mesh_format::draco), ".drc");
}

}  // namespace
}  // namespace tracemesh::proto
