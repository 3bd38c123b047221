#include "proto/mesh_format.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string_view>

namespace tracemesh::proto {
namespace {

TEST(MeshFormat, ParsesTheApiSpellings) {
  ASSERT_TRUE(parse_mesh_format("off"));
  EXPECT_EQ(*parse_mesh_format("off"), mesh_format::off);
  ASSERT_TRUE(parse_mesh_format("draco"));
  EXPECT_EQ(*parse_mesh_format("draco"), mesh_format::draco);
}

TEST(MeshFormat, RejectsOtherSpellingsWithInvalidArgument) {
  for (const char* name : {"", "OFF", "Draco", "drc", ".off", "off ", " off", "obj", "draco\n", "glb_raw", "GLB", "msms"}) {
    const result<mesh_format> parsed = parse_mesh_format(name);
    ASSERT_FALSE(parsed) << name;
    EXPECT_EQ(parsed.error().code(), errc::invalid_argument);
    EXPECT_NE(parsed.error().message().find("format"), std::string::npos);
    EXPECT_EQ(parsed.error().message().find('\n'), std::string::npos) << "messages stay on one line";
  }
}

TEST(MeshFormat, NameIsTheInverseOfParse) {
  for (const mesh_format_info& row : mesh_formats()) {
    const result<mesh_format> parsed = parse_mesh_format(row.name);
    ASSERT_TRUE(parsed);
    EXPECT_EQ(*parsed, row.format);
    EXPECT_EQ(format_name(row.format), row.name);
  }
}

TEST(MeshFormat, EveryFormatHasExactlyOneRowAndItsEncoder) {
  std::set<mesh_format> formats;
  std::set<std::string_view> names;
  for (const mesh_format_info& row : mesh_formats()) {
    EXPECT_TRUE(formats.insert(row.format).second) << row.name;
    EXPECT_TRUE(names.insert(row.name).second) << row.name;
    EXPECT_NE(row.encode, nullptr) << row.name;
    EXPECT_EQ(&format_info(row.format), &row) << row.name;
  }
  EXPECT_EQ(formats, (std::set<mesh_format>{mesh_format::off, mesh_format::draco, mesh_format::glb,
                                            mesh_format::glb_raw, mesh_format::ply}));
  EXPECT_EQ(mesh_formats().front().format, mesh_format::off) << "the default comes first";
  EXPECT_EQ(format_names_text(), "off, draco, glb, glb-raw or ply");
}

TEST(MeshFormat, ContentTypesExtensionsAndCompressibility) {
  EXPECT_EQ(content_type(mesh_format::off), "model/vnd.off");
  EXPECT_EQ(content_type(mesh_format::draco), "application/vnd.google.draco");
  EXPECT_EQ(content_type(mesh_format::glb), "model/gltf-binary");
  EXPECT_EQ(content_type(mesh_format::glb_raw), "model/gltf-binary");
  EXPECT_EQ(content_type(mesh_format::ply), "model/x-ply");
  EXPECT_EQ(file_extension(mesh_format::off), ".off");
  EXPECT_EQ(file_extension(mesh_format::draco), ".drc");
  EXPECT_EQ(file_extension(mesh_format::glb), ".glb");
  EXPECT_EQ(file_extension(mesh_format::glb_raw), ".glb");
  EXPECT_EQ(file_extension(mesh_format::ply), ".ply");
  EXPECT_TRUE(format_info(mesh_format::off).compressible);
  EXPECT_FALSE(format_info(mesh_format::draco).compressible);
  EXPECT_FALSE(format_info(mesh_format::glb).compressible);
  EXPECT_TRUE(format_info(mesh_format::glb_raw).compressible);
  EXPECT_TRUE(format_info(mesh_format::ply).compressible);
}

TEST(MeshFormat, ExtensionsFindTheFirstRow) {
  EXPECT_EQ(*format_for_extension(".glb"), mesh_format::glb) << ".glb means the compressed GLB";
  EXPECT_EQ(*format_for_extension(".ply"), mesh_format::ply);
  EXPECT_EQ(*format_for_extension(".drc"), mesh_format::draco);
  EXPECT_FALSE(format_for_extension(".obj"));
  EXPECT_FALSE(format_for_extension("glb"));
}

}  // namespace
}  // namespace tracemesh::proto
