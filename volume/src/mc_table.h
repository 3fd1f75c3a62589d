// Marching-cubes case table, generated at static-initialisation time by
// tracing iso-segments on the six faces of the unit cell (mc_table.cpp).
// Private to the volume module; tests include it through the src/ path.
//
// Cell conventions (unit cube, corner coordinates in {0,1}^3):
//  - corner c sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1);
//  - a case is the 8-bit mask of inside corners (bit c set: corner c solid);
//  - edge e runs along axis a = e / 4 from its base corner (lower end) to
//    base | (1 << a); the base corner's two other bits are e % 4 (lower axis
//    first), see edge_base_corner().
// Faces: face f = 2 * axis + side holds the corners whose bit `axis` is `side`;
// its outward normal is (2 * side - 1) along axis.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace dentar::volume::mc {

inline constexpr int kNumCases = 256;
inline constexpr int kNumEdges = 12;
// A loop has at most 12 vertices (one per crossed edge), so at most 10
// triangles; 12 leaves room for several loops and is checked when generating.
inline constexpr int kMaxTriangles = 12;

constexpr int edge_axis(int e) { return e >> 2; }
// Lower corner of edge e.
constexpr int edge_base_corner(int e) {
  const int a = e >> 2, j = e & 3;
  const int u = (a + 1) % 3, v = (a + 2) % 3;
  const int lo = u < v ? u : v, hi = u < v ? v : u;
  return ((j & 1) << lo) | (((j >> 1) & 1) << hi);
}
constexpr int edge_tip_corner(int e) { return edge_base_corner(e) | (1 << edge_axis(e)); }

struct CaseTable {
  // Triangles of each case as triples of edge ids, counter-clockwise seen
  // from outside (their right-hand normal points from inside to outside).
  std::array<std::uint8_t, kNumCases> num_triangles{};
  std::array<std::array<std::uint8_t, 3 * kMaxTriangles>, kNumCases> triangles{};
  // Bit e set when edge e is crossed by the surface (its corners differ).
  std::array<std::uint16_t, kNumCases> crossed_edges{};
};

// The generated table (built once, thread-safe static initialisation).
const CaseTable& case_table();

// The oriented iso-loops of one case before triangulation, as sequences of
// edge ids (exposed for tests). Each crossed edge appears in exactly one loop.
std::vector<std::vector<int>> case_loops(int case_mask);

// True when cube edges a and b lie on a common face of the cell.
bool edges_share_face(int a, int b);

// The iso-segments of one face for a case, oriented as in case_loops: pairs
// (from edge, to edge). Face-local: depends only on the face's four corners.
std::vector<std::array<int, 2>> face_segments(int case_mask, int face);

}  // namespace dentar::volume::mc
