#pragma once
// shell_with_island() (shell_molecule.hpp) as xyzr text, for tests that go through a file or an upload.
#include <cstdio>
#include <string>

#include "support/shell_molecule.hpp"

namespace tracemesh::testing {

inline std::string shell_with_island_xyzr() {
  std::string text;
  char line[128];
  for (const atom& a : shell_with_island().atoms) {
    std::snprintf(line, sizeof line, "%.6f %.6f %.6f %.3f\n", a.center.x, a.center.y, a.center.z, a.radius);
    text += line;
  }
  return text;
}

}  // namespace tracemesh::testing
