#include "core/trace/line_roots.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <tuple>

#include "core/field/band_culling.hpp"
#include "core/io/pqr_reader.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

using testing::molecule_path;

block_line_roots roots_of_block(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                                line_root_stats& stats, int degree = 10) {
  std::vector<std::uint32_t> atoms;
  field.atoms_near_box(lat.block_box(block), atoms);
  block_line_roots out;
  line_root_settings settings;
  settings.degree = degree;
  line_root_finder(settings).find(field, lat, block, atoms, out, stats);
  return out;
}

/// y and z of line (j, k) of a block, as the lattice computes them.
vec3 point_on_line(const lattice& lat, const lattice_index& block, int j, int k, double x) {
  vec3 p = lat.point({0, block.j * lattice::block_cells + j, block.k * lattice::block_cells + k});
  p.x = x;
  return p;
}

std::span<const line_root> line_of(const block_line_roots& r, int line) {
  return std::span<const line_root>(r.roots).subspan(
      r.first[static_cast<std::size_t>(line)],
      r.first[static_cast<std::size_t>(line + 1)] - r.first[static_cast<std::size_t>(line)]);
}

/// For isolated spheres: the closed-form roots c_x ± √(R² − ρ²) of every line of the blocks in [lo, hi]³ must be
/// found (each exactly once, by the block whose half-open span holds it), and nothing else.
void expect_sphere_roots(const molecule& mol, double d, double t0, double h, std::int64_t lo, std::int64_t hi) {
  const gaussian_field field(mol, d, t0);
  const lattice lat(h, {-64, -64, -64});
  line_root_stats stats;
  std::size_t expected_total = 0;
  for (std::int64_t bi = lo; bi <= hi; ++bi) {
    for (std::int64_t bj = lo; bj <= hi; ++bj) {
      for (std::int64_t bk = lo; bk <= hi; ++bk) {
        const lattice_index block{bi, bj, bk};
        const block_line_roots found = roots_of_block(field, lat, block, stats);
        const box3 box = lat.block_box(block);
        for (int k = 0; k < lattice::block_cells; ++k) {
          for (int j = 0; j < lattice::block_cells; ++j) {
            const vec3 p = point_on_line(lat, block, j, k, 0);
            std::vector<line_root> expected;
            for (const atom& a : mol.atoms) {
              const double big_r2 = a.radius * a.radius * (1 + std::log(t0) / d);
              const double rho2 = (p.y - a.center.y) * (p.y - a.center.y) + (p.z - a.center.z) * (p.z - a.center.z);
              if (rho2 >= big_r2) continue;
              const double half = std::sqrt(big_r2 - rho2);
              for (const double x : {a.center.x - half, a.center.x + half}) {
                if (x >= box.lo.x && x < box.hi.x) expected.push_back({x, x < a.center.x ? 1.0 : -1.0});
              }
            }
            std::sort(expected.begin(), expected.end(), [](auto& u, auto& v) { return u.x < v.x; });
            expected_total += expected.size();
            const auto roots = line_of(found, j + lattice::block_cells * k);
            ASSERT_EQ(roots.size(), expected.size())
                << "block " << bi << ' ' << bj << ' ' << bk << " line " << j << ' ' << k;
            for (std::size_t n = 0; n < roots.size(); ++n) {
              EXPECT_NEAR(roots[n].x, expected[n].x, 1e-9);
              EXPECT_EQ(roots[n].phi_x > 0, expected[n].phi_x > 0);
            }
          }
        }
      }
    }
  }
  EXPECT_GT(expected_total, 20u);
  EXPECT_EQ(stats.lines, static_cast<std::size_t>((hi - lo + 1) * (hi - lo + 1) * (hi - lo + 1)) * 64);
}

// One atom: the line at distance ρ from the centre crosses the sphere of radius R = r·√(1 + ln(t0)/d) at
// c_x ± √(R² − ρ²).
TEST(line_roots, single_atom_closed_form) {
  molecule mol;
  mol.atoms.push_back({{0.37, 0.52, -0.41}, 1.7, 0});
  expect_sphere_roots(mol, -1, 0.5, 0.7, -1, 0);
  expect_sphere_roots(mol, -2.3, 1, 1.0, -1, 0);
  expect_sphere_roots(mol, -1, 1, 0.55, -1, 0);
}

// Two atoms far enough apart that no point within one's cutoff is near the other's sphere: two closed-form spheres.
TEST(line_roots, two_separate_atoms_closed_form) {
  molecule mol;
  mol.atoms.push_back({{-3.1, 0.2, 0.3}, 1.5, 0});
  mol.atoms.push_back({{20.3, 0.8, -0.6}, 1.9, 0});
  const gaussian_field field(mol, -1, 1);
  ASSERT_LT(std::sqrt(field.atom_at(0).cutoff2) + std::sqrt(field.atom_at(1).cutoff2) + 1.9, 23.4);
  expect_sphere_roots(mol, -1, 1, 0.7, -1, 4);
}

/// Roots of φ = t0 on [x_lo, x_hi] by a dense sign scan with gaussian_field::value: the intervals
/// [x_m, x_{m+1}] (step = (x_hi − x_lo)/samples) where the sign changes.
std::vector<std::pair<double, double>> scan_line(const gaussian_field& field, vec3 p, double x_lo, double x_hi,
                                                 int samples) {
  std::vector<std::pair<double, double>> changes;
  p.x = x_lo;
  double previous_x = x_lo;
  bool previous_inside = field.value(p) >= field.t0();
  for (int m = 1; m <= samples; ++m) {
    p.x = x_lo + (x_hi - x_lo) * m / samples;
    const bool inside = field.value(p) >= field.t0();
    if (inside != previous_inside) changes.emplace_back(previous_x, p.x);
    previous_x = p.x;
    previous_inside = inside;
  }
  return changes;
}

struct line_check {
  std::size_t roots = 0, scanned = 0, missed = 0;
  double worst_residual = 0;  ///< max |φ − t0|/t0 at the roots
};

/// Checks every root of a block against gaussian_field (residual, order, span, uniqueness, sign of φ_x) and,
/// with scan_samples > 0, counts the dense-scan sign changes with no root in them.
void check_block(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                 const block_line_roots& found, int scan_samples, line_check& check) {
  const box3 box = lat.block_box(block);
  const double t0 = field.t0();
  ASSERT_EQ(found.first[0], 0u);
  ASSERT_EQ(found.first[64], found.roots.size());
  for (int line = 0; line < 64; ++line) {
    const auto roots = line_of(found, line);
    const int j = line % 8, k = line / 8;
    for (std::size_t n = 0; n < roots.size(); ++n) {
      const vec3 p = point_on_line(lat, block, j, k, roots[n].x);
      const double value = field.value(p);
      check.worst_residual = std::max(check.worst_residual, std::abs(value - t0) / t0);
      EXPECT_LE(std::abs(value - t0), 1e-9 * t0) << "x = " << roots[n].x;
      EXPECT_GE(roots[n].x, box.lo.x);
      EXPECT_LT(roots[n].x, box.hi.x);
      vec3 gradient;
      field.value_and_gradient(p, gradient);
      EXPECT_NEAR(roots[n].phi_x, gradient.x, 1e-9 * (1 + std::abs(gradient.x)));
      if (n > 0) {
        EXPECT_LT(roots[n - 1].x, roots[n].x);
        EXPECT_TRUE(roots[n].x - roots[n - 1].x > 1e-9 || (roots[n].phi_x >= 0) != (roots[n - 1].phi_x >= 0));
      }
    }
    check.roots += roots.size();
    if (scan_samples == 0) continue;
    const vec3 p = point_on_line(lat, block, j, k, 0);
    for (const auto& bracket : scan_line(field, p, box.lo.x, box.hi.x, scan_samples)) {
      ++check.scanned;
      const auto in_bracket = [&](const line_root& r) {
        return r.x >= bracket.first - 1e-9 && r.x <= bracket.second + 1e-9;
      };
      const bool has_root = std::any_of(roots.begin(), roots.end(), in_bracket);
      if (!has_root) ++check.missed;
    }
  }
}

// Two overlapping atoms (no closed form): every root is a root of gaussian_field's φ and every sign change of a
// dense scan holds one.
TEST(line_roots, two_overlapping_atoms_match_a_dense_scan) {
  molecule mol;
  mol.atoms.push_back({{0.05, 0.1, -0.2}, 1.5, 0});
  mol.atoms.push_back({{2.2, 0.3, 0.1}, 1.2, 0});
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.6, {-64, -64, -64});
  line_check check;
  line_root_stats stats;
  for (std::int64_t bi = -1; bi <= 0; ++bi) {
    for (std::int64_t bj = -1; bj <= 0; ++bj) {
      for (std::int64_t bk = -1; bk <= 0; ++bk) {
        const lattice_index block{bi, bj, bk};
        check_block(field, lat, block, roots_of_block(field, lat, block, stats), 2000, check);
      }
    }
  }
  EXPECT_GT(check.scanned, 30u);
  EXPECT_EQ(check.missed, 0u);
  EXPECT_EQ(check.roots, check.scanned);
}

// A root on a block's upper end belongs to the next block; one just below it to this block: each appears once.
TEST(line_roots, roots_next_to_a_block_end_are_found_once) {
  const double h = 0.7, radius = 1.6;
  const lattice lat(h, {-64, -64, -64});
  const double end = static_cast<double>(8) * h;  // upper end of block i = 0 (lower end of i = 1)
  for (const double offset : {-1e-3, -1e-7, 0.0, 1e-7, 1e-3}) {
    molecule mol;
    mol.atoms.push_back({{end - radius + offset, 0, 0}, radius, 0});  // on the line j = k = 0 of block (0, 0, 0)
    const gaussian_field field(mol, -1, 1);
    line_root_stats stats;
    std::vector<double> xs;
    for (std::int64_t bi = -1; bi <= 1; ++bi) {
      const block_line_roots r = roots_of_block(field, lat, {bi, 0, 0}, stats);
      for (const line_root& root : line_of(r, 0)) xs.push_back(root.x);
    }
    ASSERT_EQ(xs.size(), 2u) << "offset " << offset;
    EXPECT_NEAR(xs[0], end - 2 * radius + offset, 1e-9);
    EXPECT_NEAR(xs[1], end + offset, 1e-9);
  }
}

result<molecule> read_molecule(const std::string& name) {
  mesh_limits limits;
  return read_pqr_file(molecule_path(name), limits);
}

// Real lines through fas2: every root is on the surface to 1e-9·t0, sorted, inside its span, unique, and the
// dense scan finds no sign change without a root (counted).
TEST(line_roots, fas2_roots_are_on_the_surface_and_complete) {
  const result<molecule> mol = read_molecule("fas2.pqr");
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  const gaussian_field field(*mol, -1, 1);
  for (const double h : {1.0, 0.7}) {
    const result<lattice> lat = make_lattice(field, h, mesh_limits{});
    ASSERT_TRUE(lat.ok());
    progress_token progress;
    const result<std::vector<lattice_index>> blocks = cull_blocks(field, *lat, progress);
    ASSERT_TRUE(blocks.ok());
    line_check check;
    line_root_stats stats;
    line_root_finder finder;
    std::vector<std::uint32_t> atoms;
    block_line_roots found;
    for (std::size_t n = 0; n < blocks->size(); ++n) {
      field.atoms_near_box(lat->block_box((*blocks)[n]), atoms);
      finder.find(field, *lat, (*blocks)[n], atoms, found, stats);
      check_block(field, *lat, (*blocks)[n], found, n % 3 == 0 ? 400 : 0, check);
    }
    std::printf(
        "[ fas2 h=%.2f ] blocks %zu, roots %zu (series %zu, bracketed %zu, rejected %zu), intervals split %zu, "
        "tangent %zu, dense-scan sign changes %zu, missed %zu, worst |phi - t0|/t0 %.2e, evaluations/line %.1f\n",
        h, blocks->size(), check.roots, stats.polynomial_roots, stats.bracketed_roots, stats.rejected_roots,
        stats.split_intervals, stats.tangent_intervals, check.scanned, check.missed, check.worst_residual,
        static_cast<double>(stats.field_evaluations) / static_cast<double>(stats.lines));
    EXPECT_EQ(check.missed, 0u);
    EXPECT_GT(check.roots, 1000u);
    EXPECT_EQ(stats.polynomial_roots + stats.bracketed_roots, check.roots);
    EXPECT_EQ(stats.tangent_intervals, 0u) << "no line of fas2's lattices is tangent to its surface";
  }
}

// Every degree mesh_params accepts (2..30) gives valid and complete roots: the bounds prove the root count whatever
// the fit, which only seeds the polishing (at degree 2 or 3 the series misses many roots that the bounds then
// bracket).
TEST(line_roots, every_allowed_degree_gives_valid_complete_roots) {
  const result<molecule> mol = read_molecule("fas2.pqr");
  ASSERT_TRUE(mol.ok());
  const gaussian_field field(*mol, -1, 1);
  const result<lattice> lat = make_lattice(field, 1.0, mesh_limits{});
  ASSERT_TRUE(lat.ok());
  progress_token progress;
  const result<std::vector<lattice_index>> blocks = cull_blocks(field, *lat, progress);
  ASSERT_TRUE(blocks.ok());
  for (const int degree : {2, 3, 6, 16, legendre_max_degree}) {
    line_check check;
    line_root_stats stats;
    for (std::size_t n = 0; n < blocks->size(); n += 2) {
      check_block(field, *lat, (*blocks)[n], roots_of_block(field, *lat, (*blocks)[n], stats, degree), 200, check);
    }
    std::printf(
        "[ fas2 degree %d ] roots %zu (series %zu, bracketed %zu, rejected %zu), scan sign changes %zu, "
        "missed %zu\n",
        degree, check.roots, stats.polynomial_roots, stats.bracketed_roots, stats.rejected_roots, check.scanned,
        check.missed);
    EXPECT_EQ(check.missed, 0u) << "degree " << degree;
  }
}

// The roots do not depend on the fit: at degree 3 (four nodes per fit, a poor series) and at degree 10, every block
// of fas2 gets the same roots to 1e-9 Å, though the low-degree series misses many of them (the bounds bracket them).
TEST(line_roots, the_roots_do_not_depend_on_the_fit) {
  const result<molecule> mol = read_molecule("fas2.pqr");
  ASSERT_TRUE(mol.ok());
  const gaussian_field field(*mol, -1, 1);
  const result<lattice> lat = make_lattice(field, 1.0, mesh_limits{});
  ASSERT_TRUE(lat.ok());
  progress_token progress;
  const result<std::vector<lattice_index>> blocks = cull_blocks(field, *lat, progress);
  ASSERT_TRUE(blocks.ok());
  std::array<line_root_stats, 2> stats;
  std::size_t roots = 0;
  for (const lattice_index& block : *blocks) {
    const block_line_roots poor = roots_of_block(field, *lat, block, stats[0], 3);
    const block_line_roots good = roots_of_block(field, *lat, block, stats[1], 10);
    ASSERT_EQ(poor.first, good.first);
    for (std::size_t n = 0; n < good.roots.size(); ++n) {
      EXPECT_NEAR(poor.roots[n].x, good.roots[n].x, 1e-9);
      EXPECT_EQ(poor.roots[n].phi_x > 0, good.roots[n].phi_x > 0);
    }
    roots += good.roots.size();
  }
  EXPECT_GT(roots, 1000u);
  EXPECT_GT(stats[0].bracketed_roots, stats[1].bracketed_roots);
  EXPECT_GT(stats[0].bracketed_roots, roots / 100) << "the degree-3 series misses roots";
}

// A line that grazes an atom's surface, 1e-9·r inside it, crosses it twice 6e-5·r apart: the intervals between the
// samples are halved until the bounds prove each half, and both roots are found. A line exactly tangent to it (a
// double root) leaves one interval undecided: counted as tangent, and its roots counted by the signs at its ends
// (both below t0: none).
TEST(line_roots, a_grazing_line_is_resolved_by_halving_and_a_tangent_one_is_counted) {
  const double h = 0.5, r = 1.5;
  const lattice lat(h, {-64, -64, -64});
  for (const double inset : {1e-9, 0.0}) {
    molecule mol;
    // Line (j, k) = (3, 0) of block (0, 0, 0) lies at y = 1.5, z = 0, at r·(1 − inset) from the centre (t0 = 1: the
    // surface is the sphere of radius r); no other line of the block comes within 0.04 Å² in ρ² of tangency.
    const double centre_z = 0.1, rho = r * (1 - inset);
    mol.atoms.push_back({{1.9, 3 * h - std::sqrt(rho * rho - centre_z * centre_z), centre_z}, r, 0});
    const gaussian_field field(mol, -1, 1);
    line_root_stats stats;
    const block_line_roots found = roots_of_block(field, lat, {0, 0, 0}, stats);
    const auto roots = line_of(found, 3);
    if (inset > 0) {
      ASSERT_EQ(roots.size(), 2u);
      const double half = std::sqrt(r * r - rho * rho);
      EXPECT_NEAR(roots[0].x, 1.9 - half, 1e-9);
      EXPECT_NEAR(roots[1].x, 1.9 + half, 1e-9);
      EXPECT_GT(stats.split_intervals, 0u);
      EXPECT_EQ(stats.tangent_intervals, 0u);
    } else {
      EXPECT_EQ(roots.size(), 0u);
      EXPECT_GT(stats.tangent_intervals, 0u);
    }
  }
}

// Dips (line_root_settings::dip_ratio), the seeds of the search for untouched cavities. Two atoms of radius 1.5 at
// x = 2.8 and 5.2 on the line y = z = 0, t0 = 2.5: along that line φ has its minimum at x = 4 (by symmetry), of
// 2·e^(1 − 1.44/2.25) = 2.87 = 1.15·t0, so the line dips towards t0 there without reaching it (it crosses the
// surface only at the dumbbell's two ends). The lines one cell away (y or z = 1) stay below t0 (at most about
// e^(1 − 1/2.25) + e^(1 − 6.76/2.25) = 1.88): no root, no dip.
TEST(line_roots, a_line_that_dips_towards_t0_between_two_atoms_reports_one_dip) {
  molecule mol;
  mol.atoms.push_back({{2.8, 0, 0}, 1.5, 0});
  mol.atoms.push_back({{5.2, 0, 0}, 1.5, 0});
  const gaussian_field field(mol, -1, 2.5);
  const lattice lat(1.0, {-64, -64, -64});
  std::vector<std::uint32_t> atoms;
  field.atoms_near_box(lat.block_box({0, 0, 0}), atoms);
  for (const double ratio : {0.0, 1.1, 1.5}) {
    line_root_settings settings;
    settings.dip_ratio = ratio;
    line_root_finder finder(settings);
    block_line_roots found;
    line_root_stats stats;
    finder.find(field, lat, {0, 0, 0}, atoms, found, stats);
    if (ratio < 1.15) {
      EXPECT_TRUE(found.dips.empty()) << "ratio " << ratio;
      continue;
    }
    ASSERT_EQ(found.dips.size(), 1u);
    EXPECT_EQ(found.dips[0].line, 0);
    EXPECT_NEAR(found.dips[0].x, 4.0, 0.2) << "the node next to the minimum";
    ASSERT_EQ(line_of(found, 0).size(), 2u) << "the dumbbell's two ends";
    EXPECT_LT(line_of(found, 0)[0].x, found.dips[0].x);
    EXPECT_GT(line_of(found, 0)[1].x, found.dips[0].x);
    EXPECT_TRUE(line_of(found, 1).empty());
  }
}

TEST(line_roots, no_atoms_no_roots) {
  molecule mol;
  mol.atoms.push_back({{100, 100, 100}, 1.5, 0});
  const gaussian_field field(mol, -1, 1);
  const lattice lat(1.0, {-64, -64, -64});
  block_line_roots found;
  found.roots.push_back({1, 1});  // overwritten
  line_root_stats stats;
  line_root_finder().find(field, lat, {0, 0, 0}, {}, found, stats);
  EXPECT_TRUE(found.roots.empty());
  for (const std::uint32_t first : found.first) EXPECT_EQ(first, 0u);
  EXPECT_EQ(stats.lines, 64u);
  EXPECT_EQ(stats.proven_lines, 64u) << "φ = 0 < t0 on every span: nothing to sample";
  EXPECT_EQ(stats.field_evaluations, 0u);
  EXPECT_EQ(stats.fits, 0u);
  // Without the bounds, every span is sampled and fitted.
  line_root_settings settings;
  settings.prove_root_free = false;
  line_root_finder unproven(settings);
  line_root_stats sampled;
  unproven.find(field, lat, {0, 0, 0}, {}, found, sampled);
  EXPECT_TRUE(found.roots.empty());
  EXPECT_EQ(sampled.proven_lines, 0u);
  EXPECT_EQ(sampled.field_evaluations, 64u * 24u);  // 2 × 11 nodes and the 2 ends
  EXPECT_EQ(sampled.fits, 128u);
  EXPECT_EQ(sampled.quiet_fits, 128u);
}

// The spans that the bounds prove one-sided (line_root_settings::prove_root_free) hold no root and no dip: over
// every culled block of fas2, at a smooth and a sharp kernel and two spacings, the roots and dips found with the
// proof are those found by sampling every span, bit for bit, while most spans are skipped.
TEST(line_roots, spans_proven_one_sided_hold_no_root_and_the_rest_are_the_same_bits) {
  const result<molecule> mol = read_molecule("fas2.pqr");
  ASSERT_TRUE(mol.ok());
  for (const double d : {-1.0, -6.0}) {
    for (const double spacing : {0.93, 0.66}) {
      const gaussian_field field(*mol, d, 1);
      const result<lattice> lat = make_lattice(field, spacing, mesh_limits{});
      ASSERT_TRUE(lat.ok());
      progress_token progress;
      const result<std::vector<lattice_index>> blocks = cull_blocks(field, *lat, progress);
      ASSERT_TRUE(blocks.ok());
      line_root_settings proven_settings, sampled_settings;
      proven_settings.dip_ratio = sampled_settings.dip_ratio = 1.5;
      sampled_settings.prove_root_free = false;
      line_root_finder proven(proven_settings), sampled(sampled_settings);
      line_root_stats proven_stats, sampled_stats;
      std::vector<std::uint32_t> atoms;
      block_line_roots a, b;
      for (const lattice_index& block : *blocks) {
        field.atoms_near_box(lat->block_box(block), atoms);
        proven.find(field, *lat, block, atoms, a, proven_stats);
        sampled.find(field, *lat, block, atoms, b, sampled_stats);
        ASSERT_EQ(a.first, b.first) << "d " << d << ", h " << spacing;
        for (std::size_t r = 0; r < a.roots.size(); ++r) {
          EXPECT_EQ(a.roots[r].x, b.roots[r].x);
          EXPECT_EQ(a.roots[r].phi_x, b.roots[r].phi_x);
        }
        ASSERT_EQ(a.dips.size(), b.dips.size());
        for (std::size_t n = 0; n < a.dips.size(); ++n) {
          EXPECT_EQ(a.dips[n].line, b.dips[n].line);
          EXPECT_EQ(a.dips[n].x, b.dips[n].x);
        }
      }
      std::printf("[ fas2 d=%g h=%.2f ] %zu spans, %zu proven one-sided; evaluations %zu → %zu\n", d, spacing,
                  proven_stats.lines, proven_stats.proven_lines, sampled_stats.field_evaluations,
                  proven_stats.field_evaluations);
      EXPECT_GT(sampled_stats.polynomial_roots, 0u);
      EXPECT_GT(2 * proven_stats.proven_lines, proven_stats.lines) << "most spans are far from the surface";
      EXPECT_LT(proven_stats.field_evaluations, sampled_stats.field_evaluations);
    }
  }
}

// Same bits whatever the history of the finder (scratch reuse) and through the free function.
TEST(line_roots, deterministic) {
  const result<molecule> mol = read_molecule("fas2.pqr");
  ASSERT_TRUE(mol.ok());
  const gaussian_field field(*mol, -1, 1);
  const result<lattice> lat = make_lattice(field, 0.8, mesh_limits{});
  ASSERT_TRUE(lat.ok());
  progress_token progress;
  const result<std::vector<lattice_index>> blocks = cull_blocks(field, *lat, progress);
  ASSERT_TRUE(blocks.ok());
  line_root_finder warm;
  std::vector<std::uint32_t> atoms;
  line_root_stats stats;
  for (std::size_t n = blocks->size(); n-- > 0;) {  // reverse order: different scratch history
    const lattice_index& block = (*blocks)[n];
    field.atoms_near_box(lat->block_box(block), atoms);
    block_line_roots a, b;
    warm.find(field, *lat, block, atoms, a, stats);
    line_root_finder().find(field, *lat, block, atoms, b, stats);  // a fresh finder
    ASSERT_EQ(a.first, b.first);
    ASSERT_EQ(a.roots.size(), b.roots.size());
    for (std::size_t r = 0; r < a.roots.size(); ++r) {
      EXPECT_EQ(a.roots[r].x, b.roots[r].x);
      EXPECT_EQ(a.roots[r].phi_x, b.roots[r].phi_x);
    }
  }
}


}  // namespace
}  // namespace tracemesh
