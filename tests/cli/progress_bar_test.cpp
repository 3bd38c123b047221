#include "cli/progress_bar.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <regex>
#include <string>
#include <vector>

#include "core/io/pqr_reader.hpp"
#include "core/stage_weights.hpp"
#include "support/test_paths.hpp"

namespace tracemesh::cli {
namespace {

/// Everything written to a temporary stream.
std::string contents(std::FILE* stream) {
  std::fflush(stream);
  std::rewind(stream);
  std::string text;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, stream)) > 0) text.append(buffer, n);
  return text;
}

/// The percentages drawn, in order.
std::vector<int> percents(const std::string& drawn) {
  std::vector<int> out;
  const std::regex shown(R"(tracemesh: (\w+) +(\d+)%)");
  for (auto it = std::sregex_iterator(drawn.begin(), drawn.end(), shown); it != std::sregex_iterator(); ++it) {
    out.push_back(std::stoi((*it)[2]));
  }
  return out;
}

TEST(ProgressBar, ShowsTheWholeRunsWeightedPercentage) {
  std::FILE* stream = std::tmpfile();
  ASSERT_NE(stream, nullptr);
  {
    progress_bar bar(stream, true, mesh_method::lattice, refine_mode::full);
    bar.update(mesh_stage::refining, 0.0);  // a stage change: drawn at once
  }
  const std::vector<int> drawn = percents(contents(stream));
  std::fclose(stream);
  ASSERT_EQ(drawn.size(), 1u);
  const double expected = overall_progress(mesh_method::lattice, refine_mode::full, mesh_stage::refining, 0.0);
  EXPECT_EQ(drawn[0], static_cast<int>(expected * 100)) << "not the stage's own 0%";
  EXPECT_GT(drawn[0], 0);
}

TEST(ProgressBar, ARealRunDrawsANonDecreasingPercentage) {
  auto mol = read_pqr_file(testing::molecule_path("fas2.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  for (const mesh_method method : {mesh_method::lattice, mesh_method::trace}) {
    std::FILE* stream = std::tmpfile();
    ASSERT_NE(stream, nullptr);
    mesh_params params;
    params.method = method;
    {
      progress_bar bar(stream, true, params.method, params.refine);
      progress_token token([&bar](mesh_stage stage, double fraction) { bar.update(stage, fraction); });
      ASSERT_TRUE(mesh_molecule(*mol, params, mesh_limits{}, token).ok());
    }
    const std::vector<int> drawn = percents(contents(stream));
    std::fclose(stream);
    ASSERT_GE(drawn.size(), 3u) << method_name(method);
    for (std::size_t i = 1; i < drawn.size(); ++i) EXPECT_GE(drawn[i], drawn[i - 1]) << method_name(method) << i;
  }
}

TEST(ProgressBar, DrawsNothingWhenDisabled) {
  std::FILE* stream = std::tmpfile();
  ASSERT_NE(stream, nullptr);
  {
    progress_bar bar(stream, false, mesh_method::trace, refine_mode::none);
    bar.update(mesh_stage::tracing, 0.5);
  }
  EXPECT_TRUE(contents(stream).empty());
  std::fclose(stream);
}

}  // namespace
}  // namespace tracemesh::cli
