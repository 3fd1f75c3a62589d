// Properties of the generated marching-cubes table: closed, consistently
// oriented, 2-manifold loops in every case; faces agree between neighbouring
// cells; no degenerate triangles; outward orientation checked exactly with
// the divergence theorem.
#include "../src/mc_table.h"  // private header, tested directly

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <utility>
#include <vector>

namespace dentar::volume::mc {
namespace {

using Vec = std::array<double, 3>;

Vec corner_pos(int c) { return {double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)}; }
Vec edge_mid(int e) {
  const Vec a = corner_pos(edge_base_corner(e)), b = corner_pos(edge_tip_corner(e));
  return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}
Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
bool in(int mask, int c) { return (mask >> c) & 1; }

std::vector<std::array<int, 3>> triangles(int mask) {
  const CaseTable& t = case_table();
  std::vector<std::array<int, 3>> out;
  for (int i = 0; i < t.num_triangles[mask]; ++i)
    out.push_back(
        {t.triangles[mask][3 * i], t.triangles[mask][3 * i + 1], t.triangles[mask][3 * i + 2]});
  return out;
}

TEST(McTable, EdgeNumberingIsAPermutationOfCubeEdges) {
  std::set<std::pair<int, int>> seen;
  for (int e = 0; e < kNumEdges; ++e) {
    const int a = edge_base_corner(e), b = edge_tip_corner(e);
    EXPECT_EQ(a ^ b, 1 << edge_axis(e));
    EXPECT_LT(a, b);
    seen.insert({a, b});
  }
  EXPECT_EQ(seen.size(), 12u);
}

TEST(McTable, LoopsAreClosedAndCoverCrossedEdgesOnce) {
  const CaseTable& t = case_table();
  for (int mask = 0; mask < kNumCases; ++mask) {
    SCOPED_TRACE(mask);
    int covered = 0;
    for (const auto& loop : case_loops(mask)) {
      EXPECT_GE(loop.size(), 3u);
      for (const int e : loop) {
        EXPECT_TRUE((t.crossed_edges[mask] >> e) & 1) << "edge " << e << " not crossed";
        EXPECT_FALSE((covered >> e) & 1) << "edge " << e << " in two loops";
        covered |= 1 << e;
      }
    }
    EXPECT_EQ(covered, t.crossed_edges[mask]);
    EXPECT_EQ(t.num_triangles[mask] == 0, mask == 0 || mask == 255);
  }
}

TEST(McTable, TrianglesAreOriented2ManifoldWithFaceSegmentsAsBoundary) {
  for (int mask = 0; mask < kNumCases; ++mask) {
    SCOPED_TRACE(mask);
    std::set<std::pair<int, int>> boundary;
    for (int f = 0; f < 6; ++f)
      for (const auto& s : face_segments(mask, f)) boundary.insert({s[0], s[1]});
    std::map<std::pair<int, int>, int> directed;
    for (const auto& tri : triangles(mask))
      for (int k = 0; k < 3; ++k) ++directed[{tri[k], tri[(k + 1) % 3]}];
    for (const auto& [e, n] : directed) {
      EXPECT_EQ(n, 1) << "directed edge " << e.first << "->" << e.second << " repeated";
      const bool reverse_used = directed.count({e.second, e.first}) > 0;
      if (boundary.count(e)) {
        EXPECT_FALSE(reverse_used) << "boundary segment used both ways";
      } else {
        // Interior diagonal: its reverse is used once, and it must not lie
        // in a cube face (it would be shared with the neighbour cell).
        EXPECT_TRUE(reverse_used) << "open edge " << e.first << "->" << e.second;
        EXPECT_FALSE(edges_share_face(e.first, e.second))
            << "diagonal " << e.first << "-" << e.second << " lies in a face";
      }
    }
    for (const auto& s : boundary) EXPECT_TRUE(directed.count(s)) << "segment not in a triangle";
  }
}

TEST(McTable, NoDegenerateTriangles) {
  for (int mask = 0; mask < kNumCases; ++mask) {
    for (const auto& tri : triangles(mask)) {
      EXPECT_TRUE(tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) << mask;
      const Vec n =
          cross(sub(edge_mid(tri[1]), edge_mid(tri[0])), sub(edge_mid(tri[2]), edge_mid(tri[0])));
      EXPECT_GT(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1e-6) << mask;
    }
  }
}

// The inside region of the cell is bounded by the iso-surface (normal
// outward = toward air) and by the inside parts of the cube faces, so the
// surface's vector area equals minus the sum of n_face * inside face area.
// This checks orientation and topology of every case exactly (vertices at
// edge midpoints).
TEST(McTable, OrientationMatchesDivergenceTheorem) {
  for (int mask = 0; mask < kNumCases; ++mask) {
    SCOPED_TRACE(mask);
    Vec area{0, 0, 0};
    for (const auto& tri : triangles(mask)) {
      const Vec n =
          cross(sub(edge_mid(tri[1]), edge_mid(tri[0])), sub(edge_mid(tri[2]), edge_mid(tri[0])));
      for (int a = 0; a < 3; ++a) area[a] += n[a] / 2;
    }
    Vec expected{0, 0, 0};
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = 0; side < 2; ++side) {
        int c[4], n_in = 0;
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        const int cu[4] = {0, 1, 1, 0}, cv[4] = {0, 0, 1, 1};
        for (int i = 0; i < 4; ++i) {
          c[i] = (side << axis) | (cu[i] << u) | (cv[i] << v);
          n_in += in(mask, c[i]);
        }
        double a_in = 0;
        if (n_in == 1) a_in = 0.125;
        if (n_in == 3) a_in = 0.875;
        if (n_in == 4) a_in = 1.0;
        if (n_in == 2) a_in = in(mask, c[0]) == in(mask, c[2]) ? 0.25 : 0.5;  // diagonal: separated
        expected[axis] -= (side ? 1.0 : -1.0) * a_in;
      }
    }
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(area[a], expected[a], 1e-12) << "axis " << a;
  }
}

// Two cells sharing a face must draw the same segments on it, in opposite
// directions (each sees the face from its own outside).
TEST(McTable, SharedFacesAgreeBetweenNeighbourCells) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int mask = 0; mask < kNumCases; ++mask) {
      // Cell A's upper face (side 1) is cell B's lower face (side 0): copy
      // A's upper corners into B's lower corners.
      int b_mask = 0;
      for (int c = 0; c < 8; ++c)
        if (((c >> axis) & 1) && in(mask, c)) b_mask |= 1 << (c & ~(1 << axis));
      auto to_b = [&](int e) {
        const int base = edge_base_corner(e) & ~(1 << axis);
        for (int f = 0; f < kNumEdges; ++f)
          if (edge_axis(f) == edge_axis(e) && edge_base_corner(f) == base) return f;
        return -1;
      };
      std::set<std::pair<int, int>> a_segs, b_segs;
      for (const auto& s : face_segments(mask, 2 * axis + 1))
        a_segs.insert({to_b(s[1]), to_b(s[0])});  // reversed
      for (const auto& s : face_segments(b_mask, 2 * axis)) b_segs.insert({s[0], s[1]});
      EXPECT_EQ(a_segs, b_segs) << "axis " << axis << " mask " << mask;
    }
  }
}

// A case and its complement cross the same edges. Without an ambiguous face
// their loops are the same, reversed; with one, the face rule (separate the
// inside corners) joins the other pair, so only the edge set is shared.
TEST(McTable, ComplementaryCasesRelate) {
  const CaseTable& t = case_table();
  int unambiguous = 0;
  for (int mask = 0; mask < kNumCases; ++mask) {
    const int comp = 255 - mask;
    EXPECT_EQ(t.crossed_edges[mask], t.crossed_edges[comp]);
    bool ambiguous = false;
    for (int f = 0; f < 6; ++f) ambiguous |= face_segments(mask, f).size() == 2;
    if (ambiguous) continue;
    ++unambiguous;
    auto canonical = [](std::vector<int> loop) {
      std::rotate(loop.begin(), std::min_element(loop.begin(), loop.end()), loop.end());
      return loop;
    };
    std::set<std::vector<int>> a, b;
    for (auto loop : case_loops(mask)) {
      std::reverse(loop.begin(), loop.end());
      a.insert(canonical(loop));
    }
    for (const auto& loop : case_loops(comp)) b.insert(canonical(loop));
    EXPECT_EQ(a, b) << mask;
  }
  EXPECT_GT(unambiguous, 100);
}

}  // namespace
}  // namespace dentar::volume::mc
