#pragma once
// A molecule from a literal list of atoms, for the unit tests' small synthetic molecules.
#include <utility>
#include <vector>

#include "core/molecule.hpp"

namespace tracemesh::testing {

inline molecule atoms(std::vector<atom> list) { return molecule{std::move(list), 0}; }

}  // namespace tracemesh::testing
