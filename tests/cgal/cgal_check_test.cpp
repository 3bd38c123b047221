// The CGAL certificate of cgal_check.hpp (the only translation unit that includes CGAL), and tests showing that
// the certificate itself tells good meshes from bad ones.
#include "cgal/cgal_check.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <iterator>
#include <numbers>
#include <sstream>

#include "support/analysis_meshes.hpp"

namespace tracemesh::testing {
namespace {

using kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using point = kernel::Point_3;
using cgal_mesh = CGAL::Surface_mesh<point>;
using face_index = cgal_mesh::Face_index;
namespace pmp = CGAL::Polygon_mesh_processing;

point to_point(const vec3& p) { return {p.x, p.y, p.z}; }

bool indices_in_range(const surface_mesh& mesh) {
  return std::all_of(mesh.triangles.begin(), mesh.triangles.end(), [&](const auto& t) {
    return t[0] < mesh.positions.size() && t[1] < mesh.positions.size() && t[2] < mesh.positions.size();
  });
}

/// Areas per component and, for closed meshes without self-intersections, orientation and nesting per component.
std::vector<cgal_component> describe_components(const cgal_mesh& mesh, std::size_t components, bool orientable) {
  std::vector<std::size_t> component_of_face(mesh.number_of_faces());
  auto face_component = CGAL::make_property_map(component_of_face);
  pmp::connected_components(mesh, face_component);
  std::vector<cgal_component> result(components);
  for (const face_index f : mesh.faces()) result[get(face_component, f)].area += pmp::face_area(f, mesh);
  if (orientable) {
    std::vector<bool> outward;
    std::vector<std::size_t> nesting;
    std::vector<std::size_t> volume_of_face(mesh.number_of_faces());
    pmp::volume_connected_components(mesh, CGAL::make_property_map(volume_of_face),
                                     CGAL::parameters::is_cc_outward_oriented(std::ref(outward))
                                         .nesting_levels(std::ref(nesting))
                                         .face_connected_component_map(face_component));
    for (std::size_t c = 0; c < components && c < outward.size() && c < nesting.size(); ++c) {
      result[c].outward_oriented = outward[c];
      result[c].nesting_level = nesting[c];
    }
  }
  std::stable_sort(result.begin(), result.end(),
                   [](const cgal_component& a, const cgal_component& b) { return a.area > b.area; });
  return result;
}

}  // namespace

cgal_certificate check_with_cgal(const surface_mesh& input) {
  cgal_certificate certificate;
  if (!indices_in_range(input)) return certificate;
  std::vector<point> points;
  points.reserve(input.positions.size());
  for (const vec3& p : input.positions) points.push_back(to_point(p));
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(input.triangles.size());
  for (const auto& t : input.triangles) polygons.push_back({t[0], t[1], t[2]});
  if (!pmp::is_polygon_soup_a_polygon_mesh(polygons)) return certificate;

  cgal_mesh mesh;
  pmp::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  certificate.polygon_mesh = true;
  certificate.closed = CGAL::is_closed(mesh);
  std::vector<std::pair<face_index, face_index>> pairs;
  pmp::self_intersections(mesh, std::back_inserter(pairs));
  certificate.self_intersecting_pairs = pairs.size();
  std::vector<std::size_t> component_of_face(mesh.number_of_faces());
  certificate.components = pmp::connected_components(mesh, CGAL::make_property_map(component_of_face));
  certificate.area = pmp::area(mesh);
  const bool orientable = certificate.closed && certificate.self_intersecting_pairs == 0;
  if (certificate.closed) certificate.volume = pmp::volume(mesh);
  if (orientable) certificate.bounds_a_volume = pmp::does_bound_a_volume(mesh);
  certificate.component_details = describe_components(mesh, certificate.components, orientable);
  return certificate;
}

std::string describe(const cgal_certificate& c) {
  std::ostringstream out;
  out << "polygon_mesh=" << c.polygon_mesh << " closed=" << c.closed
      << " self_intersecting_pairs=" << c.self_intersecting_pairs << " components=" << c.components
      << " bounds_a_volume=" << c.bounds_a_volume << " area=" << c.area << " volume=" << c.volume;
  return out.str();
}

std::size_t cgal_count_intersecting_pairs_brute_force(const surface_mesh& soup) {
  std::vector<kernel::Triangle_3> triangles;
  for (const auto& t : soup.triangles) {
    triangles.emplace_back(to_point(soup.positions[t[0]]), to_point(soup.positions[t[1]]),
                           to_point(soup.positions[t[2]]));
  }
  std::size_t count = 0;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    for (std::size_t j = i + 1; j < triangles.size(); ++j) {
      count += CGAL::do_intersect(triangles[i], triangles[j]) ? 1 : 0;
    }
  }
  return count;
}

// ---------------------------------------------------------------------------------------------------------------
// The certificate itself

namespace {

TEST(CgalCheck, SphereIsCertified) {
  const cgal_certificate c = check_with_cgal(icosphere(3, 2.0));
  EXPECT_TRUE(c.certified()) << describe(c);
  EXPECT_EQ(c.components, 1u);
  ASSERT_EQ(c.component_details.size(), 1u);
  EXPECT_TRUE(c.component_details[0].outward_oriented);
  EXPECT_NEAR(c.area, 4 * std::numbers::pi * 4, 0.02 * 4 * std::numbers::pi * 4);
  EXPECT_NEAR(c.volume, 4.0 / 3.0 * std::numbers::pi * 8, 0.03 * 4.0 / 3.0 * std::numbers::pi * 8);
}

TEST(CgalCheck, DefectsAreNotCertified) {
  surface_mesh open = icosphere(2);
  open.triangles.pop_back();
  cgal_certificate c = check_with_cgal(open);
  EXPECT_TRUE(c.polygon_mesh);
  EXPECT_FALSE(c.closed);
  EXPECT_FALSE(c.certified());

  surface_mesh overlapping = icosphere(2);
  append(overlapping, icosphere(2, 1.0, {0.5, 0, 0}));
  c = check_with_cgal(overlapping);
  EXPECT_GT(c.self_intersecting_pairs, 0u);
  EXPECT_FALSE(c.certified());

  surface_mesh inside_out = icosphere(2);
  reverse_orientation(inside_out);
  c = check_with_cgal(inside_out);
  EXPECT_LT(c.volume, 0);
  ASSERT_EQ(c.component_details.size(), 1u);
  EXPECT_FALSE(c.component_details[0].outward_oriented);
  EXPECT_FALSE(c.certified());

  surface_mesh bad_index = icosphere(1);
  bad_index.triangles.push_back({0, 1, 1000});
  EXPECT_FALSE(check_with_cgal(bad_index).polygon_mesh);
}

TEST(CgalCheck, CavityInsideAShellBoundsAVolume) {
  surface_mesh mesh = icosphere(2, 3.0);
  surface_mesh inner = icosphere(2, 1.0);
  reverse_orientation(inner);
  append(mesh, inner);
  const cgal_certificate c = check_with_cgal(mesh);
  EXPECT_TRUE(c.certified()) << describe(c);
  ASSERT_EQ(c.component_details.size(), 2u);
  EXPECT_TRUE(c.component_details[0].outward_oriented);
  EXPECT_EQ(c.component_details[0].nesting_level, 0u);
  EXPECT_FALSE(c.component_details[1].outward_oriented);
  EXPECT_EQ(c.component_details[1].nesting_level, 1u);
}

}  // namespace
}  // namespace tracemesh::testing
