#pragma once
// An independent certificate of a tracemesh::surface_mesh computed with CGAL 5.5 (Surface_mesh + Polygon Mesh
// Processing, Epick kernel: exact predicates), to check tracemesh's own analysis (core/mesh_analysis.hpp) and,
// through it, the meshes of tracemesh::mesh_molecule.
//
// This header does not include CGAL: check_with_cgal() is compiled once, in cgal_check_test.cpp (the cgal_tests
// executable globs tests/cgal/*_test.cpp), so any test of that executable can call it without paying CGAL's
// compile time again.
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "core/mesh.hpp"

namespace tracemesh::testing {

/// One connected component as CGAL sees it.
struct cgal_component {
  double area = 0;                ///< Å² (PMP::face_area summed over the component)
  bool outward_oriented = false;  ///< PMP::is_outward_oriented of the component alone (closed meshes only)
  std::size_t nesting_level = 0;  ///< how many other components enclose it (closed meshes only)
};

struct cgal_certificate {
  /// The triangles form an oriented 2-manifold (PMP::is_polygon_soup_a_polygon_mesh: no repeated index, every
  /// edge in at most two triangles traversed in opposite directions, manifold vertices). Nothing below is
  /// computed when false (indices out of range also make it false).
  bool polygon_mesh = false;
  bool closed = false;                      ///< CGAL::is_closed: no border edges
  std::size_t self_intersecting_pairs = 0;  ///< PMP::self_intersections (pairs of faces)
  std::size_t components = 0;               ///< PMP::connected_components (faces joined by edges)
  /// PMP::does_bound_a_volume: closed, no self-intersection, outer shells outward and nested shells alternating
  /// (a cavity of a molecule points into itself). False when it cannot be evaluated (open or self-intersecting).
  bool bounds_a_volume = false;
  double area = 0;    ///< Å², PMP::area
  double volume = 0;  ///< Å³, PMP::volume (closed meshes only; signed, outer shells minus cavities)
  std::vector<cgal_component> component_details;  ///< sorted by decreasing area

  /// Every outermost shell (even nesting level) points outward and every cavity (odd level) into itself.
  bool orientation_matches_nesting() const {
    return std::all_of(component_details.begin(), component_details.end(),
                       [](const cgal_component& c) { return c.outward_oriented == (c.nesting_level % 2 == 0); });
  }

  /// What a molecular surface mesh must satisfy.
  bool certified() const {
    return polygon_mesh && closed && self_intersecting_pairs == 0 && bounds_a_volume && orientation_matches_nesting();
  }
};

/// Certifies `mesh` with CGAL. Never throws on a bad mesh: what cannot be evaluated is reported as false/0.
cgal_certificate check_with_cgal(const surface_mesh& mesh);

/// A one-line summary for test failure messages.
std::string describe(const cgal_certificate& certificate);

/// Pairs of triangles that intersect according to CGAL::do_intersect(Triangle_3, Triangle_3) (exact predicates),
/// by brute force over all pairs. For triangle soups whose triangles share no vertex index (the plain geometric
/// test applies to every pair). Quadratic: small inputs only.
std::size_t cgal_count_intersecting_pairs_brute_force(const surface_mesh& soup);

}  // namespace tracemesh::testing
