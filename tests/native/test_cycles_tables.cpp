// The tables of material/cycles_tables.h: the committed data (written by this
// project's generator, ptir_gen_cycles_tables) against Cycles' own values as
// compiled into Blender 4.5.15 and 5.0.1 (tests/data/cycles_tables_4.5.txt, copied
// by scripts/extract_cycles_tables.py; the sums equal those of Blender v5.1.2's
// intern/cycles/scene/shader.tables, and table_ggx_E's first and last rows equal
// shader.tables at commit 09cf4924cc65e989ffde4965b87302c0ec431c96), the committed
// data against a fresh run of the generator's quadrature, and the interpolation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "ptir/material/cycles_tables.h"
#include "ptir/math/rng.h"

using namespace ptir;
namespace fs = std::filesystem;

namespace {

fs::path tests_dir() {
  fs::path f(__FILE__);
  if (f.is_relative()) f = fs::path(PTIR_TEST_TMP).parent_path() / "tests" / f;
  return f.lexically_normal().parent_path().parent_path();
}

// name -> values, from the "# name count sum" sections of the data file.
std::map<std::string, std::vector<double>> cycles_values() {
  std::ifstream in(tests_dir() / "data" / "cycles_tables_4.5.txt");
  std::map<std::string, std::vector<double>> out;
  std::string line, current;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    if (line.rfind("# ggx", 0) == 0) {
      std::string hash;
      ss >> hash >> current;
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    double v;
    while (ss >> v) out[current].push_back(v);
  }
  return out;
}

const CyclesTable kAll[] = {CyclesTable::GgxE, CyclesTable::GgxEavg, CyclesTable::GenSchlickIorS, CyclesTable::GenSchlickS};

}  // namespace

// Bounds: the generator's quadrature (256^2 visible normals per cell) converges to
// ~1e-4 of Cycles' Monte Carlo values (2^20..2^26 samples per cell) everywhere but
// the last four slices of ggx_gen_schlick_s (z >= 12/15, exponents 1.25 and below: (1 - c)^e
// has an infinite slope at c = 1 that both estimators resolve slowly; no Principled
// lookup reads those slices: the metal reads z = 0.5, between slices 7 and 8).
TEST(CyclesTables, MatchCyclesOwnValues) {
  const auto cycles = cycles_values();
  for (CyclesTable t : kAll) {
    const CyclesTableShape s = cycles_table_shape(t);
    const auto it = cycles.find(cycles_table_name(t));
    ASSERT_NE(it, cycles.end()) << cycles_table_name(t);
    ASSERT_EQ(int(it->second.size()), s.size()) << cycles_table_name(t);
    const float* ours = cycles_table_data(t);
    double worst = 0, sum = 0, worst_spiky = 0;
    int at = 0;
    for (int k = 0; k < s.size(); ++k) {
      const double d = std::fabs(ours[k] - it->second[size_t(k)]);
      const bool spiky = t == CyclesTable::GenSchlickS && k / (s.nx * s.ny) >= 12;
      if (spiky) {
        worst_spiky = std::max(worst_spiky, d);
        continue;
      }
      sum += d;
      if (d > worst) worst = d, at = k;
    }
    std::printf("  %-22s max |ours - Cycles| %.2g (cell %d: %.6f vs %.6f), mean %.2g%s\n", cycles_table_name(t), worst,
                at, ours[at], it->second[size_t(at)], sum / s.size(),
                t == CyclesTable::GenSchlickS ? (" (slices z >= 12/15: max " + std::to_string(worst_spiky) + ")").c_str() : "");
    EXPECT_LT(worst, 4e-4) << cycles_table_name(t);
    EXPECT_LT(sum / s.size(), 5e-5) << cycles_table_name(t);
    EXPECT_LT(worst_spiky, 1e-2) << cycles_table_name(t);
  }
}

// The committed data is the generator's: random cells recomputed with 64^2 samples
// (whose own quadrature error is below 1e-3 of the 256^2 values outside the spiky slices).
TEST(CyclesTables, CommittedDataIsTheGenerators) {
  Rng rng(35);
  for (CyclesTable t : kAll) {
    const CyclesTableShape s = cycles_table_shape(t);
    for (int i = 0; i < 6; ++i) {
      const int x = int(rng.next() * s.nx) % s.nx, y = int(rng.next() * s.ny) % s.ny;
      const int z = t == CyclesTable::GenSchlickS ? int(rng.next() * 12) % 12 : int(rng.next() * s.nz) % s.nz;
      const double fresh = cycles_table_cell(t, x, y, z, 64);
      const float stored = cycles_table_data(t)[(z * s.ny + y) * s.nx + x];
      EXPECT_NEAR(stored, fresh, 1e-3) << cycles_table_name(t) << " cell " << x << "," << y << "," << z;
    }
  }
}

// Cycles' lookup_table.h: linear per axis, exact at the nodes, clamped outside [0, 1].
TEST(CyclesTables, InterpolationAsCycles) {
  const CyclesTableShape s = cycles_table_shape(CyclesTable::GenSchlickIorS);
  const float* d = cycles_table_data(CyclesTable::GenSchlickIorS);
  auto at = [&](int x, int y, int z) { return double(d[(z * s.ny + y) * s.nx + x]); };
  // A node.
  EXPECT_FLOAT_EQ(cycles_table_read(CyclesTable::GenSchlickIorS, 3.0f / 15, 7.0f / 15, 4.0f / 15), at(3, 7, 4));
  // Trilinear between nodes, weights 0.25 / 0.5 / 0.75.
  const float x = (3 + 0.25f) / 15, y = (7 + 0.5f) / 15, z = (4 + 0.75f) / 15;
  double want = 0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int c = 0; c < 2; ++c)
        want += (a ? 0.25 : 0.75) * (b ? 0.5 : 0.5) * (c ? 0.75 : 0.25) * at(3 + a, 7 + b, 4 + c);
  EXPECT_NEAR(cycles_table_read(CyclesTable::GenSchlickIorS, x, y, z), want, 1e-6);
  // Clamped outside.
  EXPECT_FLOAT_EQ(cycles_table_read(CyclesTable::GgxEavg, 1.7f), float(cycles_table_data(CyclesTable::GgxEavg)[31]));
  // The roughness slope of a dual-number lookup is the slope of the interpolant.
  const Dual<1> r = Dual<1>::variable((5 + 0.4f) / 31, 0);
  const Dual<1> e = cycles_table_read(CyclesTable::GgxE, r, 0.5f);
  const float* E = cycles_table_data(CyclesTable::GgxE);
  const double slope = 31.0 * (0.5 * (E[15 * 32 + 6] - E[15 * 32 + 5]) + 0.5 * (E[16 * 32 + 6] - E[16 * 32 + 5]));
  EXPECT_NEAR(e.d[0], slope, 1e-4);
}
